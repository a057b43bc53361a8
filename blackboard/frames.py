"""Frames and pose history: a tree of SE(2) frames with static and time-stamped edges.

Frames follow REP-105: `world` (map), `local` (odometry; never jumps), `vehicle` (moves), and sensor
frames fixed on the vehicle. The HELM posts `local←vehicle` poses (the moving vehicle position); the
position estimator posts `world←local` corrections (the perceived vehicle position). A frame at a
time is "frame@t": a point in `vehicle@t1` is relative to the vehicle as it was at t1 [s].

`lookup(target, s, source, t)` answers T_{target@s ← source@t}. When both times are equal, or the
frames' lowest common ancestor does not move below the fixed frame, the tree is walked through that
ancestor. Otherwise it goes through a *fixed frame*: the deepest common ancestor that is inertial
(default `local`, then `world`; REP-105's odom and map), or the root — so `vehicle@t1 → vehicle@t2`
uses odometry alone and `vehicle@t → world` composes `world←local(t) ∘ local←vehicle(t)`.

The algebra is the one of `wire.se2` (on `SE2` tuples). Dynamic edges interpolate linearly in x, y
and along the shorter arc in yaw (`interpolate_tuple`); they keep a bounded
history (`history` [s] behind the newest sample, at most `max_samples`). Times before the oldest
sample raise PastExtrapolationError, after the newest FutureExtrapolationError (unless within the
edge's `hold` [s]: then the newest sample answers, for low-rate corrections). Static edges answer
for any time.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from blackboard.errors import (
    FutureExtrapolationError,
    InvalidTokenError,
    PastExtrapolationError,
    UnknownFrameError,
)
from blackboard.geometry import Pose2D
from wire.se2 import IDENTITY, SE2, compose_tuple, interpolate_tuple, inverse_tuple, transform_points

__all__ = ["FrameTree", "DEFAULT_INERTIAL_FRAMES"]

DEFAULT_INERTIAL_FRAMES = ("world", "local")
_EPS = 1e-9


@dataclass
class _Edge:
    parent: str
    static: SE2 | None = None
    hold: float = 0.0
    ts: list[float] = field(default_factory=list)
    xs: list[float] = field(default_factory=list)
    ys: list[float] = field(default_factory=list)
    yaws: list[float] = field(default_factory=list)

    def newest(self) -> float:
        return math.inf if self.static is not None else self.ts[-1]

    def at(self, t: float, child: str) -> SE2:
        if self.static is not None:
            return self.static
        ts = self.ts
        if t < ts[0] - _EPS:
            raise PastExtrapolationError(
                f"{self.parent}←{child} at t={t:.6f} s is before the oldest pose kept (t={ts[0]:.6f} s)"
            )
        if t > ts[-1] + _EPS:
            if t - ts[-1] <= self.hold:
                return (self.xs[-1], self.ys[-1], self.yaws[-1])
            raise FutureExtrapolationError(
                f"{self.parent}←{child} at t={t:.6f} s is after the newest pose received (t={ts[-1]:.6f} s)"
            )
        i = bisect.bisect_left(ts, t)
        if i < len(ts) and abs(ts[i] - t) <= _EPS:
            return (self.xs[i], self.ys[i], self.yaws[i])
        if i == 0:
            return (self.xs[0], self.ys[0], self.yaws[0])
        if i >= len(ts):
            return (self.xs[-1], self.ys[-1], self.yaws[-1])
        t0, t1 = ts[i - 1], ts[i]
        return interpolate_tuple((self.xs[i - 1], self.ys[i - 1], self.yaws[i - 1]), (self.xs[i], self.ys[i], self.yaws[i]),
                                 (t - t0) / (t1 - t0))


class FrameTree:
    """A tree of frames with static edges and bounded, interpolated pose histories."""

    def __init__(
        self,
        *,
        history: float = 60.0,
        max_samples: int = 20_000,
        inertial: tuple[str, ...] = DEFAULT_INERTIAL_FRAMES,
    ) -> None:
        self.history = float(history)
        self.max_samples = int(max_samples)
        self.inertial = tuple(inertial)
        self._edges: dict[str, _Edge] = {}  # child -> edge to its parent

    # ------------------------------------------------------------------ writing
    def frames(self) -> set[str]:
        """Return every frame named by an edge."""
        out = set(self._edges)
        out.update(e.parent for e in self._edges.values())
        return out

    def edges(self) -> list[tuple[str, str, bool]]:
        """Return (parent, child, is_static) for every edge."""
        return [(e.parent, c, e.static is not None) for c, e in self._edges.items()]

    def _edge_for(self, parent: str, child: str) -> _Edge:
        for name in (parent, child):
            if not isinstance(name, str) or not name or len(name) > 128:
                raise InvalidTokenError(f"frame name {name!r} must be a non-empty string")
        if parent == child:
            raise InvalidTokenError(f"frame {child!r} cannot be its own parent")
        edge = self._edges.get(child)
        if edge is not None:
            if edge.parent != parent:
                raise InvalidTokenError(f"frame {child!r} already has parent {edge.parent!r}, not {parent!r}")
            return edge
        # reject cycles: parent must not descend from child
        p: str | None = parent
        while p is not None:
            if p == child:
                raise InvalidTokenError(f"{parent}←{child} would make a cycle")
            e = self._edges.get(p)
            p = e.parent if e else None
        edge = _Edge(parent=parent)
        self._edges[child] = edge
        return edge

    def set_static(self, parent: str, child: str, pose: Pose2D | SE2) -> None:
        """Fix child in parent for all times (e.g. a sensor on the vehicle)."""
        p = pose.as_tuple() if isinstance(pose, Pose2D) else tuple(map(float, pose))
        _check_pose(p)
        edge = self._edge_for(parent, child)
        if edge.ts:
            raise InvalidTokenError(f"{parent}←{child} already has a pose history; it cannot become static")
        edge.static = p  # type: ignore[assignment]

    def add_pose(self, parent: str, child: str, pose: Pose2D | SE2, stamp: float, *, hold: float = 0.0) -> None:
        """Record child's pose in parent at `stamp` [s]; `hold` [s]: how long the newest sample stays valid."""
        p = pose.as_tuple() if isinstance(pose, Pose2D) else tuple(map(float, pose))
        _check_pose(p)
        stamp = float(stamp)
        if not math.isfinite(stamp) or not (math.isfinite(hold) or hold == math.inf) or hold < 0:
            raise InvalidTokenError(f"pose stamp {stamp!r} and hold {hold!r} must be finite and hold ≥ 0")
        edge = self._edge_for(parent, child)
        if edge.static is not None:
            raise InvalidTokenError(f"{parent}←{child} is static; it takes no timed poses")
        edge.hold = float(hold)
        ts = edge.ts
        if not ts or stamp > ts[-1]:
            i = len(ts)
        else:
            i = bisect.bisect_left(ts, stamp)
            if i < len(ts) and abs(ts[i] - stamp) <= _EPS:  # same time: replace
                edge.xs[i], edge.ys[i], edge.yaws[i] = p
                return
        ts.insert(i, stamp)
        edge.xs.insert(i, p[0])
        edge.ys.insert(i, p[1])
        edge.yaws.insert(i, p[2])
        # bound the history
        cut = bisect.bisect_left(ts, ts[-1] - self.history)
        cut = max(cut, len(ts) - self.max_samples)
        if cut > 0:
            del ts[:cut], edge.xs[:cut], edge.ys[:cut], edge.yaws[:cut]

    def history_wire(self) -> list[list]:
        """Return every edge with all it keeps: [parent, child, static pose or None, hold [s] (None: forever), ts, xs, ys, yaws]."""
        return [[e.parent, c, list(e.static) if e.static is not None else None, None if e.hold == math.inf else e.hold,
                 list(e.ts), list(e.xs), list(e.ys), list(e.yaws)] for c, e in self._edges.items()]

    @classmethod
    def from_history_wire(cls, edges: list, *, history: float, max_samples: int, inertial: tuple[str, ...]) -> "FrameTree":
        """Return a tree holding `edges` (as `history_wire` gives them) with the same bounds as the tree that gave them."""
        tree = cls(history=history, max_samples=max_samples, inertial=inertial)
        for parent, child, static, hold, ts, xs, ys, yaws in edges:
            if static is not None:
                tree.set_static(parent, child, tuple(map(float, static)))
                continue
            edge = tree._edge_for(parent, child)
            edge.hold = math.inf if hold is None else float(hold)
            edge.ts, edge.xs, edge.ys, edge.yaws = list(map(float, ts)), list(map(float, xs)), list(map(float, ys)), list(map(float, yaws))
            if not (len(edge.ts) == len(edge.xs) == len(edge.ys) == len(edge.yaws)) or not edge.ts:
                raise InvalidTokenError(f"{parent}←{child}: a pose history needs as many stamps as poses, at least one")
        return tree

    # ------------------------------------------------------------------ reading
    def _chain(self, frame: str) -> list[str]:
        """Return [frame, parent, ..., root]."""
        out = [frame]
        e = self._edges.get(frame)
        while e is not None:
            out.append(e.parent)
            if len(out) > 256:
                raise UnknownFrameError("frame tree too deep")
            e = self._edges.get(e.parent)
        return out

    def _fixed(self, a: str, b: str, same_time: bool) -> tuple[str, list[str], list[str]]:
        ca, cb = self._chain(a), self._chain(b)
        if ca[-1] != cb[-1]:
            known = self.frames()
            missing = [f for f in (a, b) if f not in known]
            if missing:
                raise UnknownFrameError(f"unknown frame {missing[0]!r}; known: {', '.join(sorted(known)) or '(none)'}")
            raise UnknownFrameError(f"frames {a!r} and {b!r} are not connected")
        sb = set(cb)
        lca = next(f for f in ca if f in sb)
        pa, pb = ca[: ca.index(lca)], cb[: cb.index(lca)]
        if same_time:
            return lca, pa, pb
        common = ca[ca.index(lca):]
        fixed = next((f for f in common if f in self.inertial), common[-1])
        upper = common[: common.index(fixed)]  # lca … below fixed: must not move for lca to serve
        if all(self._edges[f].static is not None for f in upper):
            return lca, pa, pb
        return fixed, ca[: ca.index(fixed)], cb[: cb.index(fixed)]

    def _down(self, path: list[str], t: float) -> SE2:
        """Return T_{top←path[0]}(t) for path = [frame, parent, ..., (child of top)]."""
        T = IDENTITY
        for f in reversed(path):
            T = compose_tuple(T, self._edges[f].at(t, f))
        return T

    def _latest(self, path: list[str]) -> float:
        """Return the newest time [s] every moving edge on `path` answers (held samples included;
        if every edge holds forever, the newest sample time)."""
        dyn = [self._edges[f] for f in path if self._edges[f].static is None]
        if not dyn:
            return 0.0
        t = min(e.ts[-1] + e.hold for e in dyn)
        return t if math.isfinite(t) else max(e.ts[-1] for e in dyn)

    def connected(self, a: str, b: str) -> bool:
        """Return True if a transform between frames a and b can exist (same frame or same tree)."""
        if a == b:
            return True
        return self._chain(a)[-1] == self._chain(b)[-1]

    def time_invariant(self, a: str, b: str) -> bool:
        """Return True if T_{a@s ← b@t} does not depend on s or t."""
        if a == b and a not in self._edges:
            return True
        try:
            _, pa, pb = self._fixed(a, b, same_time=False)
        except UnknownFrameError:
            return False
        return all(self._edges[f].static is not None for f in pa + pb)

    def lookup(self, target: str, target_stamp: float | None, source: str, source_stamp: float | None) -> SE2:
        """Return T_{target@target_stamp ← source@source_stamp} as (x [m], y [m], yaw [rad]).

        A None stamp means the newest time the history answers for that frame.
        """
        if target == source and (target_stamp == source_stamp or target not in self._edges):
            return IDENTITY
        same = target_stamp is not None and source_stamp is not None and abs(target_stamp - source_stamp) <= _EPS
        fixed, pa, pb = self._fixed(target, source, same_time=same)
        ta = self._latest(pa) if target_stamp is None else float(target_stamp)
        tb = self._latest(pb) if source_stamp is None else float(source_stamp)
        Ta = self._down(pa, ta)
        Tb = self._down(pb, tb)
        return compose_tuple(inverse_tuple(Ta), Tb)

    def lookup_pose(self, parent: str, child: str, stamp: float | None = None) -> Pose2D:
        """Return the pose of `child` in `parent` at `stamp` [s] (None: newest)."""
        if stamp is None:
            fixed, pa, pb = self._fixed(parent, child, same_time=True)
            stamp = self._latest(pa + pb)
        x, y, yaw = self.lookup(parent, stamp, child, stamp)
        return Pose2D(x=x, y=y, yaw=yaw)

    def latest_time(self, frame: str) -> float:
        """Return the newest time [s] the history answers for `frame` relative to the root."""
        chain = self._chain(frame)
        return self._latest(chain[:-1])

    def transform_points(
        self, points: np.ndarray, src: str, src_stamp: float | None, dst: str, dst_stamp: float | None
    ) -> np.ndarray:
        """Map (N,2) float64 points [m] from `src@src_stamp` into `dst@dst_stamp`."""
        return transform_points(self.lookup(dst, dst_stamp, src, src_stamp), points)


def _check_pose(p: tuple) -> None:
    if len(p) != 3 or not all(isinstance(v, float) and math.isfinite(v) for v in p):
        raise InvalidTokenError(f"pose {p!r} must be three finite numbers (x [m], y [m], yaw [rad])")

