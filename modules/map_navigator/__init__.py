"""The MAP NAVIGATOR: route selection on the path graph, segmentation by navigation mode, route
segment descriptions copied from the map, one segment at a time, replanning on failure.

The service and its process (`service`, `main`) use the blackboard and load on first use, so EDDIE
can reuse route selection and segmentation without loading the blackboard.
"""

import importlib as _importlib

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
    "build_parser", "main", "navigator_main", "start_position",
    "MapData", "load_map", "map_object",
    "Leg", "NoRouteError", "Route", "RouteError", "RouteOptions", "UnknownPlaceError", "edge_cost", "edge_forbidden",
    "select_route",
    "SegmentOptions", "SegmentPlan", "fillet_corner", "fillet_radius", "heading_change", "segment_route",
    "MapNavigator", "ServiceOptions",
    "DESCRIBE_REACH_M", "TURN_SPEED_M_S", "NavigatorOptions", "Planned", "StepJob", "vehicle_describe_radius", "vehicle_turn_radius",
]

#: names served lazily: the blackboard-bound parts
_LAZY = {"build_parser": "main", "main": "main", "navigator_main": "main", "start_position": "main",
         "MapNavigator": "service", "ServiceOptions": "service"}


def __getattr__(name: str):
    """Load the blackboard-bound parts on first use."""
    if name in _LAZY:
        sub = _importlib.import_module(f"{__name__}.{_LAZY[name]}")
        # importing the submodule bound its name here (`main`): bind the functions instead
        globals().update({n: getattr(sub, n) for n, m in _LAZY.items() if m == _LAZY[name]})
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
