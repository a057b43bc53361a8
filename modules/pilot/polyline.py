"""Arc-length geometry on 2-D polylines (N,2) float64 [m], in whatever frame the caller uses."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from modules.pilot.errors import PilotError

__all__ = ["PathLine", "PolylineError"]


class PolylineError(PilotError, ValueError):
    """A polyline is unusable (fewer than 2 distinct vertices, non-finite values)."""


@dataclass(frozen=True)
class PathLine:
    """A polyline with cumulative arc length; vertices (N,2) float64 [m], s (N,) float64 [m]."""

    xy: np.ndarray
    s: np.ndarray

    @classmethod
    def from_points(cls, pts) -> "PathLine":
        """Build from (N,2) points [m], dropping repeated vertices; raise PolylineError if degenerate."""
        arr = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
        if not np.all(np.isfinite(arr)):
            raise PolylineError("polyline has non-finite coordinates")
        keep = [0]
        for i in range(1, len(arr)):
            if np.hypot(*(arr[i] - arr[keep[-1]])) > 1e-9:
                keep.append(i)
        arr = arr[keep]
        if len(arr) < 2:
            raise PolylineError("polyline needs at least 2 distinct vertices")
        seg = np.hypot(*np.diff(arr, axis=0).T)
        return cls(xy=arr, s=np.concatenate([[0.0], np.cumsum(seg)]))

    @property
    def length(self) -> float:
        """Return the total arc length [m]."""
        return float(self.s[-1])

    def point_at(self, s: float) -> np.ndarray:
        """Return the point (2,) at arc length s [m], clamped to the ends."""
        s = min(max(s, 0.0), self.length)
        i = int(np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2))
        t = (s - self.s[i]) / (self.s[i + 1] - self.s[i])
        return self.xy[i] + t * (self.xy[i + 1] - self.xy[i])

    def heading_at(self, s: float) -> float:
        """Return the tangent direction [rad] at arc length s [m] (the segment containing s)."""
        s = min(max(s, 0.0), self.length)
        i = int(np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2))
        d = self.xy[i + 1] - self.xy[i]
        return math.atan2(d[1], d[0])

    def slice(self, s0: float, s1: float) -> np.ndarray:
        """Return the sub-polyline (M,2) between arc lengths s0 < s1 [m], ends interpolated."""
        s0 = min(max(s0, 0.0), self.length)
        s1 = min(max(s1, s0), self.length)
        inner = [self.xy[i] for i in range(len(self.s)) if s0 < self.s[i] < s1]
        return np.vstack([self.point_at(s0), *inner, self.point_at(s1)]) if inner else np.vstack(
            [self.point_at(s0), self.point_at(s1)]
        )

    def project(self, p) -> tuple[float, float]:
        """Return (s [m], signed lateral offset [m], left positive) of the closest point to p."""
        p = np.asarray(p, dtype=np.float64)
        a = self.xy[:-1]
        d = np.diff(self.xy, axis=0)
        ll = np.einsum("ij,ij->i", d, d)
        t = np.clip(np.einsum("ij,ij->i", p - a, d) / ll, 0.0, 1.0)
        c = a + t[:, None] * d
        dist = np.hypot(*(p - c).T)
        i = int(np.argmin(dist))
        cross = d[i, 0] * (p[1] - a[i, 1]) - d[i, 1] * (p[0] - a[i, 0])
        return float(self.s[i] + t[i] * math.sqrt(ll[i])), float(math.copysign(dist[i], cross))

    def offset(self, lateral: float, step: float = 0.5) -> np.ndarray:
        """Return the polyline resampled every `step` [m] and shifted `lateral` [m] to the left."""
        n = max(2, int(math.ceil(self.length / step)) + 1)
        out = []
        for s in np.linspace(0.0, self.length, n):
            h = self.heading_at(min(s, self.length - 1e-9)) if s < self.length else self.heading_at(self.length)
            p = self.point_at(s)
            out.append(p + lateral * np.array([-math.sin(h), math.cos(h)]))
        return np.asarray(out)
