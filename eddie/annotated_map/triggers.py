"""Triggers: walk the line travelled since the last cycle through the grid and fire each trigger once.

Each cycle the manager hands the walker the vehicle's new position in `world`. The segment from the
last position is walked through the grid (supercover: every cell it touches), the candidates are
tested exactly (segment meets the location; a point within its `reach` [m]) and fired in the order
the segment reaches them. A fired trigger is marked `used` and never fires again. Polygons with
`enter` / `leave` triggers fire on the transition outside→inside / inside→outside (both, in order,
when one cycle's segment passes right through the polygon).

**Position jumps** (seed Figure 3.3). When the navigator's world←local changes, the vehicle's
`world` position jumps without the vehicle moving. `jump(to)` applies this policy to the jump segment:

- *small* jump (length ≤ `small_jump_m`, 2 m by default) *forward* (its direction within 90° of the
  heading of travel): treated as travel — the triggers it crosses fire (they lie where the vehicle
  truly was, only the estimate lagged);
- *large* jump forward: the crossed triggers are **skipped**: marked used, not sent, and each is
  reported (`TriggerEvent.skipped`) so the manager can publish that it was jumped over;
- *backward* jump (any length): nothing fires; crossed used triggers stay used unless the
  annotation says `refire`, in which case they are re-armed and fire when the vehicle crosses them
  again. Enter/leave state follows the new position silently.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Literal

import shapely
import shapely.ops

from eddie.annotated_map.annotation import Annotation
from eddie.annotated_map.database import AnnotationDatabase

__all__ = ["TriggerEvent", "TriggerWalker", "JumpKind", "SMALL_JUMP_M"]

#: Jumps up to this length [m] fire what they cross (when forward).
SMALL_JUMP_M = 2.0

JumpKind = Literal["travel", "small_forward", "large_forward", "backward"]
EventKind = Literal["fired", "skipped", "rearmed"]


@dataclass(frozen=True)
class TriggerEvent:
    """One trigger outcome: the annotation, what happened, where along the segment [m `world`], how it was reached."""

    annotation: Annotation
    kind: EventKind
    x: float
    y: float
    via: JumpKind
    edge: Literal["cross", "enter", "leave"]

    @property
    def skipped(self) -> bool:
        """Return whether the trigger was jumped over (not sent)."""
        return self.kind == "skipped"


class TriggerWalker:
    """The trigger state of one vehicle over an annotation database (last position, heading, polygons inside)."""

    def __init__(self, db: AnnotationDatabase, *, small_jump_m: float = SMALL_JUMP_M) -> None:
        self.db = db
        self.small_jump_m = small_jump_m
        self.last: tuple[float, float] | None = None
        self.heading: tuple[float, float] | None = None
        self._inside: set[str] = set()

    def reset(self, x: float, y: float) -> list[TriggerEvent]:
        """Start at (x, y) [m] `world` without firing; polygons already around the vehicle count as entered silently."""
        self.last = (float(x), float(y))
        p = shapely.Point(self.last)
        self._inside = {aid for aid in self.db.candidates([self.db.grid.cell_of(x, y)])
                        if self.db.get(aid).trigger in ("enter", "leave") and self.db.geometry(aid).covers(p)}
        return []

    def changed(self, added: Iterable[str], removed: Iterable[str]) -> None:
        """Follow annotations added to or removed from the database: added polygons around the vehicle count as entered silently."""
        self._inside.difference_update(removed)
        if self.last is None:
            return
        p = shapely.Point(self.last)
        self._inside.update(aid for aid in added
                            if self.db.get(aid).trigger in ("enter", "leave") and self.db.geometry(aid).covers(p))

    def advance(self, x: float, y: float) -> list[TriggerEvent]:
        """Travel to (x, y) [m] `world`: fire every unused trigger the segment from the last position meets."""
        if self.last is None:
            return self.reset(x, y)
        (x0, y0) = self.last
        dx, dy = x - x0, y - y0
        n = math.hypot(dx, dy)
        if n > 1e-9:
            self.heading = (dx / n, dy / n)
        return self._walk(x, y, "travel")

    def jump(self, x: float, y: float) -> list[TriggerEvent]:
        """Jump to (x, y) [m] `world` (a new world←local): apply the position-jump policy (module docstring)."""
        if self.last is None:
            return self.reset(x, y)
        (x0, y0) = self.last
        dx, dy = x - x0, y - y0
        n = math.hypot(dx, dy)
        if n <= 1e-9:
            return []
        h = self.heading
        if h is not None and dx * h[0] + dy * h[1] < 0:
            return self._walk(x, y, "backward")
        return self._walk(x, y, "small_forward" if n <= self.small_jump_m else "large_forward")

    def _walk(self, x: float, y: float, via: JumpKind) -> list[TriggerEvent]:
        x0, y0 = self.last  # type: ignore[misc]
        self.last = (float(x), float(y))
        db = self.db
        cells = db.grid.supercover(x0, y0, x, y)
        cand = db.candidates(cells)  # reach-padded annotations are indexed on their padded cells
        seg = shapely.LineString([(x0, y0), (x, y)]) if (x0, y0) != (x, y) else shapely.Point(x0, y0)
        start, end = shapely.Point(x0, y0), shapely.Point(x, y)
        found: list[tuple[float, Annotation, str, tuple[float, float]]] = []
        for aid in cand:
            a = db.get(aid)
            if a.trigger == "none":
                continue
            g = db.geometry(aid)
            if a.trigger == "cross":
                if seg.distance(g) <= a.reach + 1e-9:
                    at = _first_contact(seg, g, a.reach)
                    found.append((start.distance(shapely.Point(at)), a, "cross", at))
                continue
            was = aid in self._inside
            now = g.covers(end)
            entered = not was and seg.intersects(g)
            left = (was or entered) and not now
            if now:
                self._inside.add(aid)
            else:
                self._inside.discard(aid)
            if a.trigger == "enter" and entered:
                at = _first_contact(seg, g, 0.0)
            elif a.trigger == "leave" and left:
                at = _last_contact(seg, g)
            else:
                continue
            found.append((start.distance(shapely.Point(at)), a, a.trigger, at))
        found.sort(key=lambda f: (f[0], f[1].id))
        events: list[TriggerEvent] = []
        for _, a, edge, at in found:
            cur = db.get(a.id)
            if via == "backward":
                if cur.used and cur.refire:
                    db.set_used(a.id, False)
                    events.append(TriggerEvent(cur, "rearmed", at[0], at[1], via, edge))  # type: ignore[arg-type]
                continue
            if cur.used:
                continue
            db.set_used(a.id, True)
            kind: EventKind = "skipped" if via == "large_forward" else "fired"
            events.append(TriggerEvent(db.get(a.id), kind, at[0], at[1], via, edge))  # type: ignore[arg-type]
        return events


def _first_contact(seg: shapely.Geometry, g: shapely.Geometry, reach: float) -> tuple[float, float]:
    """Return the first point [m] `world` along `seg` within `reach` of `g`."""
    if isinstance(seg, shapely.Point):
        return seg.x, seg.y
    target = g.buffer(reach) if reach > 0 else g
    inter = seg.intersection(target)
    if inter.is_empty:
        p = shapely.ops.nearest_points(seg, g)[0]
        return p.x, p.y
    d = min(seg.project(shapely.Point(c)) for c in _coords(inter))
    p = seg.interpolate(d)
    return p.x, p.y


def _last_contact(seg: shapely.Geometry, g: shapely.Geometry) -> tuple[float, float]:
    """Return the last point [m] `world` along `seg` in `g` (where the vehicle left it)."""
    if isinstance(seg, shapely.Point):
        return seg.x, seg.y
    inter = seg.intersection(g)
    if inter.is_empty:
        return tuple(shapely.get_coordinates(seg)[0])  # type: ignore[return-value]
    d = max(seg.project(shapely.Point(c)) for c in _coords(inter))
    p = seg.interpolate(d)
    return p.x, p.y


def _coords(g: shapely.Geometry) -> list[tuple[float, float]]:
    return [tuple(c) for c in shapely.get_coordinates(g)]
