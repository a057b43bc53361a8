"""Smooth velocity regulation: the commanded speed ramps within acceleration and deceleration limits."""

from __future__ import annotations

__all__ = ["VelocityRegulator"]


class VelocityRegulator:
    """Ramp the speed [m/s] toward each target at most `accel` [m/s²] up and `decel` [m/s²] down."""

    def __init__(self, accel: float, decel: float) -> None:
        if accel <= 0.0 or decel <= 0.0:
            raise ValueError("accel and decel must be > 0 [m/s²]")
        self.accel = accel
        self.decel = decel
        self.speed = 0.0

    def step(self, target: float, dt: float) -> float:
        """Return the speed [m/s] after `dt` [s] heading for `target` [m/s] (signed)."""
        dt = max(0.0, dt)
        v = self.speed
        if abs(target) > abs(v) and (target >= 0.0) == (v >= 0.0):
            rise = self.accel * dt
            v = min(target, v + rise) if target >= 0.0 else max(target, v - rise)
        else:
            fall = self.decel * dt
            v = max(target, v - fall) if target < v else min(target, v + fall)
        self.speed = v
        return v

    def reset(self, speed: float = 0.0) -> None:
        """Set the regulated speed [m/s] (after an immediate stop)."""
        self.speed = speed
