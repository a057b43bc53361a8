"""Odometry of a vehicle driving a circle, and a player of the simulator's drive interface for tests.

`CircleDrive` publishes the sim clock and the circle's odometry as the simulator does: steadily at
about RTF 5, or a burst at once, as a process held up on a loaded machine receives what queued.
"""

from __future__ import annotations

import asyncio
import math
from typing import Callable

from wire.drive import Odometry, SimClock, encode

__all__ = ["RADIUS", "SPEED", "STEP", "circle_odometry", "CircleDrive"]

RADIUS = 2.0  # [m] of the circle driven
SPEED = 1.0  # [m/s]
STEP = 0.05  # [s] sim between odometry samples (the simulator's 20 Hz)


def circle_odometry(k: int) -> Odometry:
    """Odometry sample k (sim time k·STEP [s]): `local←vehicle` on a left-hand circle of RADIUS at SPEED, from the origin."""
    t = round(k * STEP, 6)
    w = SPEED / RADIUS
    return Odometry(stamp=t, x=RADIUS * math.sin(w * t), y=RADIUS * (1.0 - math.cos(w * t)),
                    yaw=math.remainder(w * t, 2 * math.pi), v=SPEED, omega=w, distance=SPEED * t)


class CircleDrive:
    """Play the simulator: put odometry sample k on `odom_key` and sim time on `clock_key` with `put(key, payload)`."""

    def __init__(self, put: Callable[[str, bytes], None], odom_key: str, clock_key: str) -> None:
        self._put, self._odom_key, self._clock_key = put, odom_key, clock_key
        self.k = 0  # the last sample published
        self._halt = asyncio.Event()
        self._steady: asyncio.Future | None = None

    def tick(self) -> None:
        """Publish the next sample and its sim time."""
        self.k += 1
        od = circle_odometry(self.k)
        self._put(self._odom_key, encode(od))
        self._put(self._clock_key, encode(SimClock(stamp=od.stamp, rtf=5.0, rtf_actual=5.0, step=self.k)))

    def start(self) -> None:
        """Tick at about RTF 5 (a sample each STEP / 5 [s] wall) until `halt`."""
        self._halt.clear()
        self._steady = asyncio.ensure_future(self._run())

    async def _run(self) -> None:
        while not self._halt.is_set():
            self.tick()
            try:
                await asyncio.wait_for(self._halt.wait(), STEP / 5.0)
            except asyncio.TimeoutError:
                pass

    async def halt(self) -> None:
        """Stop ticking (at once) and wait until the ticker has ended."""
        self._halt.set()
        if self._steady is not None:
            await self._steady
            self._steady = None

    async def burst(self, n: int) -> tuple[int, int]:
        """Halt, publish `n` samples at once, tick on steadily; return the first and last sample of the burst."""
        await self.halt()
        first = self.k + 1
        for _ in range(n):
            self.tick()
        self.start()
        return first, self.k
