"""EDDIE's route as the monitor draws it: the mission's `route` annotations in driving order, and the current one.

Under EDDIE no module posts a route plan or a current route segment; the mission compiler leaves the
route in the annotated map as `route` annotations (seed: Navlab 1990 §3.3), one per route segment, whose
data is a `RouteSegment` (index in driving order, navigation mode, centreline in `world`, width). The
route is their centrelines joined; the current segment is the one the believed pose is on, searched
forward from the last one only (a segment passed is not taken again when the route doubles back).
"""

from __future__ import annotations

import base64
import binascii
import math
from typing import Any, Optional, Sequence

from pydantic import BaseModel, ConfigDict

from eddie.errors import EddieError
from eddie.messages.map_manager import RouteSegment, open_trigger_data

__all__ = ["RouteLeg", "AnnotatedRoute", "route_legs"]

Pt = tuple[float, float]

#: How many segments past the current one the search looks [segments].
LOOK_AHEAD = 3


class RouteLeg(BaseModel):
    """One route segment: its annotation id, index in driving order, mode, centreline (world [m]), width [m], text."""

    model_config = ConfigDict(frozen=True)
    id: str
    index: int
    mode: str = ""
    points: tuple[Pt, ...]
    width_m: float = 2.0
    text: str = ""


def _segment_data(a: dict) -> Optional[RouteSegment]:
    raw = a.get("data_base64")
    if not isinstance(raw, str) or not raw:
        return None
    try:
        msg = open_trigger_data(base64.b64decode(raw, validate=True))
    except (binascii.Error, ValueError, EddieError):
        return None
    return msg if isinstance(msg, RouteSegment) else None


def route_legs(annotations: Sequence[dict]) -> list[RouteLeg]:
    """Return the `route` annotations (as the map manager answers them, location in `world`) in driving order."""
    legs = []
    for n, a in enumerate(annotations):
        if a.get("type") != "route":
            continue
        seg = _segment_data(a)
        pts = tuple((float(x), float(y)) for x, y in (seg.points if seg is not None else a.get("points", ())))
        if len(pts) < 2:
            continue
        legs.append(RouteLeg(id=str(a.get("id", f"route{n}")), index=seg.index if seg is not None else n,
                             mode=seg.mode if seg is not None else "", points=pts,
                             width_m=seg.width if seg is not None else 2.0, text=str(a.get("text", ""))))
    return sorted(legs, key=lambda leg: leg.index)


def _dist(p: Pt, pts: Sequence[Pt]) -> float:
    best = math.inf
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        dx, dy = x1 - x0, y1 - y0
        L2 = dx * dx + dy * dy
        u = 0.0 if L2 <= 0 else max(0.0, min(1.0, ((p[0] - x0) * dx + (p[1] - y0) * dy) / L2))
        best = min(best, math.hypot(p[0] - x0 - u * dx, p[1] - y0 - u * dy))
    return best


class AnnotatedRoute:
    """The route's legs and the current one along a believed pose (see module docstring)."""

    def __init__(self, legs: Sequence[RouteLeg] = ()) -> None:
        self.legs = list(legs)
        self.current: Optional[int] = None  # position in `legs`

    def polyline(self) -> list[Pt]:
        """Return the route as one polyline (world [m]): the legs' centrelines joined, shared ends once."""
        out: list[Pt] = []
        for leg in self.legs:
            pts = list(leg.points)
            if out and math.hypot(out[-1][0] - pts[0][0], out[-1][1] - pts[0][1]) < 1e-6:
                pts = pts[1:]
            out += pts
        return out

    def locate(self, x: float, y: float) -> Optional[RouteLeg]:
        """Return the current leg for the believed pose (x, y) [m] `world`; move only forward (None: no legs)."""
        if not self.legs:
            return None
        first = 0 if self.current is None else self.current
        window = range(first, len(self.legs)) if self.current is None else range(first, min(len(self.legs), first + LOOK_AHEAD + 1))
        d = {i: _dist((x, y), self.legs[i].points) for i in window}
        best = min(d, key=lambda i: (d[i], i))
        if self.current is None or d[best] < d[self.current] - 1e-6:
            self.current = best
        return self.legs[self.current]

    def as_dict(self, leg: RouteLeg) -> dict[str, Any]:
        """Return a leg as the model's current segment: `{id, centreline, width_m, mode, index, text}`."""
        return {"id": leg.id, "centreline": leg.points, "width_m": leg.width_m, "mode": leg.mode, "index": leg.index,
                "text": leg.text}
