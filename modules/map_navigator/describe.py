"""The ROUTE SEGMENT DESCRIBER: route segment descriptions with exit conditions, constraints and objects.

Object descriptions are copied from the map: the segment's path objects first, then every other
object within `describe_radius_m` of the centreline, nearest first (the prediction PERCEPTION
matches). World frame, metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import shapely

from modules.map_navigator.mapdata import MapData
from modules.map_navigator.segments import SegmentPlan, _direction
from modules.vocabulary import DrivingConstraints, ExitCondition, RouteSegmentDescription, StepConstraints

__all__ = ["DescribeOptions", "describe_segment", "exit_condition", "lateral_offset"]


@dataclass(frozen=True)
class DescribeOptions:
    """Description settings: how far around the centreline objects are copied [m], and how many at most.

    `turn_speed_limit` [m/s] caps the speed in turn-at-intersection segments (None: the step's limit
    only): a vehicle that steers at a limited rate slows through turns (seed: Navlab §2.5.4, AMV).
    With `turn_on_arc`, a turn-at-intersection segment drops the keep-right/left side: the vehicle
    follows the turn's arc (drawn for its turning radius) and takes its side again on the next road.
    """

    describe_radius_m: float = 8.0
    max_objects: int = 48
    turn_speed_limit: float | None = None
    turn_on_arc: bool = False


def lateral_offset(keep: str | None, width: float) -> float:
    """Return the track offset from the centreline [m], + left of travel: keep right → −width/4."""
    if keep == "right":
        return -width / 4.0
    if keep == "left":
        return width / 4.0
    return 0.0


#: How close [m] the vehicle must believe it is to a step's destination to call it reached.
ARRIVAL_RADIUS_M = 1.0


def exit_condition(coords: tuple[tuple[float, float], ...], width: float, *, arrival: bool = False) -> ExitCondition:
    """Return the exit condition at the end of a centreline: a gate across the path, the end point.

    A segment that ends a step (`arrival`) must come within ARRIVAL_RADIUS_M of its end point; one
    that hands over to the next segment of the route may end anywhere within half the path's width.
    """
    end = coords[-1]
    h = _direction(coords, at_end=True)
    half = width / 2.0 + 0.5
    nx, ny = -math.sin(h), math.cos(h)
    gate = ((end[0] - nx * half, end[1] - ny * half), (end[0] + nx * half, end[1] + ny * half))
    return ExitCondition(point=end, gate=gate, heading=h, radius_m=ARRIVAL_RADIUS_M if arrival else max(1.0, width / 2.0))


def describe_segment(seg: SegmentPlan, m: MapData, *, segment_id: str, plan_id: str, index: int,
                     constraints: StepConstraints, last: bool, opts: DescribeOptions = DescribeOptions()) -> RouteSegmentDescription:
    """Return the route segment description of `seg` (the `index`-th of plan `plan_id`)."""
    desc = m.descriptions
    line = shapely.LineString(seg.coords) if seg.length > 1e-6 else shapely.Point(seg.coords[0])
    objects = [desc[o] for o in seg.path_objects if o in desc]
    seen = set(seg.path_objects)
    for _, obj in m.objects_near(line, opts.describe_radius_m):
        if len(objects) >= opts.max_objects:
            break
        if obj.id not in seen:
            seen.add(obj.id)
            objects.append(desc[obj.id])
    speed_limit, keep = constraints.speed_limit, constraints.keep
    if seg.mode == "turn-at-intersection":
        if opts.turn_speed_limit is not None:
            speed_limit = opts.turn_speed_limit if speed_limit is None else min(speed_limit, opts.turn_speed_limit)
        if opts.turn_on_arc:
            keep = None
    return RouteSegmentDescription(
        segment_id=segment_id, plan_id=plan_id, segment_index=index, mode=seg.mode,  # type: ignore[arg-type]
        path_object_ids=seg.path_objects, centreline=seg.coords, width_m=seg.width, length_m=seg.length,
        exit=exit_condition(seg.coords, seg.width, arrival=last),
        constraints=DrivingConstraints(keep=keep, lateral_offset_m=lateral_offset(keep, seg.width),
                                       speed_limit=speed_limit, stop_at_exit=last),
        objects=tuple(objects),
    )
