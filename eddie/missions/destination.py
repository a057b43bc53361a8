"""A step's destination point: beside the object the step is named after, else the map's place (seed §3.3, "stop at objects").

A step names a place (`destination: mailbox`). When the map has a landmark of that kind within
`STOP_LEAD_M` [m] of the place, the step is about that object: the vehicle is to stop beside it, and
the stop-at-object trigger steers by where the laser sees it (`eddie.obstacle_stop.stop_at_object`). The
destination point is then the object's projection on the last part of the step's route, not the
place. A map whose objects were built by driving the route (`sidewalk mapbuild`) keeps the older
map's places, and the two disagree by the mapping error (3.1 m at the AMV's mailbox, seed 0): a
vehicle that sees the object and stops at the place stopped that far from it. On a map whose place
and object agree the two points are the same within centimetres. Frame: `world` [m].
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

import shapely
from shapely.ops import substring

if TYPE_CHECKING:
    from modules.map_navigator.mapdata import MapData

__all__ = ["STOP_LEAD_M", "destination_object", "destination_point"]

#: How far before a step's destination its stop gate sits [m], and how near the place [m] an object must
#: stand to be the step's object: room for the receiver to see the object in the laser's view (±40°
#: ahead, landmarks trusted to 16 m: a kerbside mailbox leaves the view some 6 m before it) and to stop at it.
STOP_LEAD_M = 20.0


def destination_object(m: "MapData", place: str | None, xy: tuple[float, float]) -> tuple[str, tuple[float, float] | None]:
    """Return the landmark of kind `place` nearest the place `xy` (within `STOP_LEAD_M`): its id and position, or a name and None."""
    near = [(math.dist(xy, o.footprint.centroid.coords[0]), o.id, tuple(o.footprint.centroid.coords[0])) for o in m.world.objects
            if o.role == "landmark" and o.kind == (place or "")]
    near = [n for n in near if n[0] <= STOP_LEAD_M]
    if near:
        _, oid, oxy = min(near)
        return oid, (float(oxy[0]), float(oxy[1]))
    return (place or f"({xy[0]:.1f}, {xy[1]:.1f})"), None


def destination_point(goal_xy: tuple[float, float], object_xy: tuple[float, float] | None,
                      route: Sequence[Sequence[float]]) -> tuple[float, float]:
    """Return where the step ends: beside its object (`destination_object`) on the route's last 2·`STOP_LEAD_M`, else the place `goal_xy`."""
    if object_xy is None or len(route) < 2:
        return (float(goal_xy[0]), float(goal_xy[1]))
    line = shapely.LineString([(float(p[0]), float(p[1])) for p in route])
    tail = substring(line, max(0.0, line.length - 2.0 * STOP_LEAD_M), line.length)
    p = tail.interpolate(tail.project(shapely.Point(object_xy)))
    return (float(p.x), float(p.y))
