"""Odometry of a vehicle driving a circle, for tests that play the simulator's drive interface."""

from __future__ import annotations

import math

from wire.drive import Odometry

__all__ = ["RADIUS", "SPEED", "STEP", "circle_odometry"]

RADIUS = 2.0  # [m] of the circle driven
SPEED = 1.0  # [m/s]
STEP = 0.05  # [s] sim between odometry samples (the simulator's 20 Hz)


def circle_odometry(k: int) -> Odometry:
    """Odometry sample k (sim time k·STEP [s]): `local←vehicle` on a left-hand circle of RADIUS at SPEED, from the origin."""
    t = round(k * STEP, 6)
    w = SPEED / RADIUS
    return Odometry(stamp=t, x=RADIUS * math.sin(w * t), y=RADIUS * (1.0 - math.cos(w * t)),
                    yaw=math.remainder(w * t, 2 * math.pi), v=SPEED, omega=w, distance=SPEED * t)
