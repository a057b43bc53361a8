"""A short buffer of the controller's `local` poses (from its pushed `state` stream), to place a fix that names none."""

from __future__ import annotations

import bisect
from collections import deque

import numpy as np

from wire.se2 import interpolate_tuple

__all__ = ["LocalPoseBuffer"]


class LocalPoseBuffer:
    """Keep the last `span_s` [s sim] of (stamp [s], x [m], y [m], yaw [rad]) in `local`; interpolate at a stamp."""

    def __init__(self, span_s: float = 10.0) -> None:
        self.span_s = span_s
        self._t: deque[float] = deque()
        self._p: deque[tuple[float, float, float]] = deque()

    def add(self, stamp: float, x: float, y: float, yaw: float) -> None:
        """Append a pose (older or equal stamps than the newest are ignored)."""
        if self._t and stamp <= self._t[-1]:
            return
        self._t.append(stamp)
        self._p.append((x, y, yaw))
        while self._t and self._t[0] < stamp - self.span_s:
            self._t.popleft()
            self._p.popleft()

    @property
    def newest(self) -> tuple[float, np.ndarray] | None:
        """Return (stamp [s], pose (3,)) of the newest pose, or None."""
        return (self._t[-1], np.array(self._p[-1])) if self._t else None

    def at(self, stamp: float) -> np.ndarray | None:
        """Return the pose (3,) at `stamp` [s] (interpolated; None outside the buffer)."""
        if not self._t or stamp < self._t[0] or stamp > self._t[-1]:
            return None
        ts = list(self._t)
        j = bisect.bisect_left(ts, stamp)
        if ts[j] == stamp:
            return np.array(self._p[j])
        return np.array(interpolate_tuple(self._p[j - 1], self._p[j], (stamp - ts[j - 1]) / (ts[j] - ts[j - 1])))
