"""The path the controller drove, recorded in `local` against the odometer, so it can be followed again."""

from __future__ import annotations

import bisect
import math

__all__ = ["PathRecord"]


class PathRecord:
    """Record (odometer [m], x [m], y [m]) in `local` every `spacing` [m], keeping the newest `max_points`."""

    def __init__(self, spacing: float = 0.25, max_points: int = 40_000) -> None:
        self.spacing = spacing
        self.max_points = max_points
        self._s: list[float] = []
        self._xy: list[tuple[float, float]] = []

    def add(self, odometer: float, x: float, y: float) -> None:
        """Record the vehicle at (x, y) [m] in `local` when it moved `spacing` since the last point."""
        if self._xy and math.dist(self._xy[-1], (x, y)) < self.spacing:
            return
        self._s.append(odometer)
        self._xy.append((x, y))
        if len(self._s) > self.max_points:
            drop = len(self._s) - self.max_points
            del self._s[:drop], self._xy[:drop]

    def __len__(self) -> int:
        return len(self._s)

    @property
    def span(self) -> tuple[float, float] | None:
        """Return the (first, last) odometer readings [m] recorded, or None."""
        return (self._s[0], self._s[-1]) if self._s else None

    def stretch(self, odometer_from: float, odometer_to: float) -> list[tuple[float, float]]:
        """Return the points recorded between two odometer readings [m] (reversed when `to` < `from`)."""
        lo, hi = sorted((odometer_from, odometer_to))
        i = bisect.bisect_left(self._s, lo)
        j = bisect.bisect_right(self._s, hi)
        pts = self._xy[i:j]
        return pts[::-1] if odometer_to < odometer_from else pts
