"""Route vocabulary: route plans, route segment descriptions and segment results (MAP NAVIGATOR ↔ PILOT).

Seed §2.3.2: a route is decomposed into route segments with one navigation mode each; the route
segment description carries path objects, the mode, the exit condition, driving constraints and
object descriptions copied from the map. Only one segment at a time reaches the PILOT.
All coordinates are in the `world` frame [m].
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from modules.vocabulary._base import XY, Frozen, NonNeg, Polyline2, finite, token_type
from modules.vocabulary.mapdata import MapObject
from modules.vocabulary.mission import KeepSide

__all__ = [
    "NavigationMode", "NAVIGATION_MODES", "RoutePlan", "ExitCondition", "DrivingConstraints",
    "RouteSegmentDescription", "SegmentResult",
]

#: One navigation mode per route segment (seed §2.3.2); climb-stairs exists in the map for
#: vehicles that can take stairs; cross-country is an off-road goal with no road to it (Navlab 1990 §2.4):
#: the PILOT plans on the terrain map, and the segment's centreline is only the straight line to the goal.
NavigationMode = Literal[
    "follow-road", "turn-at-intersection", "go-through-intersection", "go-through-slope", "climb-stairs", "cross-country",
]
NAVIGATION_MODES: tuple[str, ...] = (
    "follow-road", "turn-at-intersection", "go-through-intersection", "go-through-slope", "climb-stairs", "cross-country",
)


@token_type("route_plan")
class RoutePlan(Frozen):
    """The whole route chosen for one mission step (seen by the MAP NAVIGATOR, CAPTAIN and monitors only).

    `revision` counts replans of the same step (0 = first plan). `polyline` is the route centreline.
    """

    plan_id: str
    mission_id: str
    step_index: Annotated[int, Field(ge=0)]
    revision: Annotated[int, Field(ge=0)] = 0
    node_ids: tuple[str, ...]
    edge_ids: tuple[str, ...]
    segment_count: Annotated[int, Field(ge=0)]
    length_m: NonNeg
    cost: NonNeg
    polyline: tuple[XY, ...]
    start_xy: XY
    goal_xy: XY
    goal_name: str | None = None
    frame: Literal["world"] = "world"


class ExitCondition(Frozen):
    """When the PILOT leaves the segment: crossing `gate` (a line across the path at its end) while

    heading along `heading` [rad], or coming within `radius_m` [m] of `point` (the segment's end on
    the centreline). World frame.
    """

    point: XY
    gate: tuple[XY, XY]
    heading: finite
    radius_m: Annotated[float, Field(gt=0.0)] = 1.0


class DrivingConstraints(Frozen):
    """How to drive in the segment: side to keep, lateral offset, speed limit, stop at exit.

    `lateral_offset_m` is the signed offset of the desired track from the centreline, positive to
    the left of the travel direction [m]; `speed_limit` [m/s] (None: vehicle's own limit).
    `stop_at_exit`: the vehicle must come to rest at the exit (the last segment of a step that stops).
    """

    keep: KeepSide | None = None
    lateral_offset_m: finite = 0.0
    speed_limit: Annotated[float, Field(gt=0.0)] | None = None
    stop_at_exit: bool = False


@token_type("route_segment")
class RouteSegmentDescription(Frozen):
    """One route segment for the PILOT: mode, path objects, centreline, exit, constraints, objects.

    `objects` are map object descriptions copied from the map (path objects first, then landmarks
    and obstacles near the segment) — the prediction PERCEPTION matches against. The MAP NAVIGATOR
    updates `state` to "cancelled" to withdraw the segment.
    """

    segment_id: str
    plan_id: str
    segment_index: Annotated[int, Field(ge=0)]
    mode: NavigationMode
    path_object_ids: tuple[str, ...]
    centreline: Polyline2
    width_m: Annotated[float, Field(gt=0.0)]
    length_m: NonNeg
    exit: ExitCondition
    constraints: DrivingConstraints = DrivingConstraints()
    objects: tuple[MapObject, ...] = ()
    state: Literal["active", "cancelled"] = "active"
    frame: Literal["world"] = "world"


@token_type("segment_result")
class SegmentResult(Frozen):
    """The PILOT's report on a route segment: success or failure with the reason.

    `end_xy` is the PILOT's estimate of the vehicle position in the world frame when it stopped
    working on the segment [m] (what the MAP NAVIGATOR replans from); `distance_m` driven in it [m].
    """

    segment_id: str
    plan_id: str
    segment_index: Annotated[int, Field(ge=0)]
    success: bool
    reason: str = ""
    end_xy: XY | None = None
    distance_m: NonNeg = 0.0
