"""The MAP NAVIGATOR: route selection on the path graph, segmentation by navigation mode, route
segment descriptions copied from the map, one segment at a time, replanning on failure.

The library parts both architectures use; the MAP NAVIGATOR's blackboard service is `codger.map_navigator`.
"""

from modules.map_navigator.describe import DescribeOptions, describe_segment, exit_condition, lateral_offset
from modules.map_navigator.mapdata import MapData, load_map, map_object
from modules.map_navigator.route import (
    Leg, NoRouteError, Route, RouteError, RouteOptions, UnknownPlaceError, edge_cost, edge_forbidden, select_route,
)
from modules.map_navigator.segments import SegmentOptions, SegmentPlan, fillet_corner, fillet_radius, heading_change, segment_route
from modules.map_navigator.stepjob import (
    DESCRIBE_REACH_M, TURN_SPEED_M_S, NavigatorOptions, Planned, StepJob, vehicle_describe_radius, vehicle_turn_radius,
)

__all__ = [
    "DescribeOptions", "describe_segment", "exit_condition", "lateral_offset",
    "MapData", "load_map", "map_object",
    "Leg", "NoRouteError", "Route", "RouteError", "RouteOptions", "UnknownPlaceError", "edge_cost", "edge_forbidden",
    "select_route",
    "SegmentOptions", "SegmentPlan", "fillet_corner", "fillet_radius", "heading_change", "segment_route",
    "DESCRIBE_REACH_M", "TURN_SPEED_M_S", "NavigatorOptions", "Planned", "StepJob", "vehicle_describe_radius", "vehicle_turn_radius",
]
