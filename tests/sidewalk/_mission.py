"""Shared steps of the end-to-end fault tests: follow a running mission."""

from __future__ import annotations

import asyncio

__all__ = ["drive_to"]


async def drive_to(system, mid: str, metres: float, timeout: float = 90.0) -> None:
    """Return once the true vehicle has driven `metres` [m] in all (statuses are the wake-ups)."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while system.recorder.distance_m() < metres and loop.time() < end:
        st = await system.next_status(mid, timeout=0.2)
        assert st is None or not st.terminal, f"the mission ended before {metres} m: {st.state} {st.reason}"
    assert system.recorder.distance_m() >= metres, f"the vehicle drove only {system.recorder.distance_m():.1f} m"
