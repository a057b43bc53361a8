"""The summed "nudge" input (seed §2.5: joystick, soft bumper): speed and curvature offsets that decay."""

from __future__ import annotations

import math

__all__ = ["NudgeSum"]


class NudgeSum:
    """Sum each source's newest (dv [m/s], dk [1/m]) offset, decaying with time constant `tau` [s] sim."""

    def __init__(self, tau: float = 1.0, floor: float = 1e-3) -> None:
        if tau <= 0.0:
            raise ValueError("tau must be > 0 [s]")
        self.tau = tau
        self.floor = floor
        self._by_source: dict[str, tuple[float, float, float]] = {}

    def set(self, source: str, dv: float, dk: float, now: float) -> None:
        """Replace `source`'s offset with (dv, dk) at sim time `now` [s]."""
        self._by_source[source] = (dv, dk, now)

    def offsets(self, now: float) -> tuple[float, float]:
        """Return the summed (dv [m/s], dk [1/m]) at sim time `now` [s]; dropping offsets that decayed away."""
        dv = dk = 0.0
        for src, (v, k, t) in list(self._by_source.items()):
            f = math.exp(-max(0.0, now - t) / self.tau)
            if max(abs(v), abs(k) * 10.0) * f < self.floor:
                del self._by_source[src]
                continue
            dv += v * f
            dk += k * f
        return dv, dk

    @property
    def active(self) -> bool:
        """Return whether any source's offset is still in force."""
        return bool(self._by_source)
