"""Obstacle stop's look for a stop's object is paced by the sim clock, not by the capture's round trip.

In lock-step a capture is served at the sim time it was asked at; a loop that asked for the next frame
at once kept the module busy at one sim time, and the simulator's barrier waited 10 s wall per step
(the AMV's stop at the mailbox, lock-step, both seeds). Here the capture answers at once, as it does in
lock-step, and the clock is the real `SimClock`.
"""

from __future__ import annotations

import asyncio

import pytest

from eddie.obstacle_stop import obstacle_stop_module as osm
from eddie.obstacle_stop.stop_at_object import ObjectCorrection
from runtime.clock import SimClock


class _Endpoint:
    """What `ObstacleStop` reads of its module: the sim clock and stream subscriptions (none arrive here)."""

    def __init__(self) -> None:
        self.clock = SimClock()

    def subscribe(self, *_args, **_kwargs) -> None:
        return None


@pytest.mark.asyncio
async def test_the_look_for_the_object_takes_one_frame_per_frame_period(monkeypatch) -> None:
    asked: list[float] = []
    m = _Endpoint()
    parked = asyncio.Event()  # set when the look waits on the sim clock
    wait_until = m.clock.wait_until

    async def parking(t: float) -> float:
        parked.set()
        return await wait_until(t)

    m.clock.wait_until = parking  # type: ignore[method-assign]

    class _Frame:
        stamp = 0.0  # no controller pose is known at it: the look has nothing to do with the frame

    async def instant_capture(module, **_kw):  # noqa: ANN001, ANN202 - the simulator's answer in lock-step: at once
        asked.append(module.clock.now())
        if len(asked) % 2:
            return _Frame()
        raise osm.CaptureError("no frame in this test")  # a failed capture waits its period too

    monkeypatch.setattr(osm, "capture_scan", instant_capture)
    stop = osm.ObstacleStop(m)  # type: ignore[arg-type]
    m.clock.advance(10.0)
    look = asyncio.ensure_future(stop._sight((0.0, 0.0), ObjectCorrection()))
    await asyncio.wait_for(parked.wait(), 5.0)  # the old loop asked again at once instead of waiting
    assert asked == [10.0]
    for k in range(1, 21):  # 2 s sim in 0.1 s ticks; a frame is due every fifth
        parked.clear()
        m.clock.advance(10.0 + 0.1 * k)
        if k % 5 == 0:
            await asyncio.wait_for(parked.wait(), 5.0)
    look.cancel()
    assert asked == pytest.approx([10.0, 10.5, 11.0, 11.5, 12.0])
