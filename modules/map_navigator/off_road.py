"""An off-road step (Navlab 1990 §2.4): no route over the path graph, one cross-country segment to the goal itself.

A destination marked `off_road` is a point reached across country: the MAP NAVIGATOR looks up no road,
and hands the PILOT one route segment of mode `cross-country` whose centreline is the straight line from
where the vehicle is believed to be to the goal, whose width is the corridor the PILOT's terrain map covers
around that line, and whose exit is the arrival rule of every step (within `ARRIVAL_RADIUS_M` of the goal,
then at rest). The PILOT plans the way itself, on the terrain tiles. World frame [m].
"""

from __future__ import annotations

import math

from modules.map_navigator.describe import exit_condition
from modules.vocabulary import DrivingConstraints, MissionStep, RoutePlan, RouteSegmentDescription

__all__ = ["OFF_ROAD_CORRIDOR_M", "OFF_ROAD_SPEED_M_S", "off_road_plan"]

#: Width [m] of the corridor around the straight line in which the PILOT keeps its terrain map (30 m a side).
OFF_ROAD_CORRIDOR_M = 60.0
#: Speed limit [m/s] across country: the planner's path is checked for a vehicle that keeps to it within
#: 0.25 m, and the laser sees the ground 6–20 m ahead; the 1990 cross-country runs went at walking pace.
OFF_ROAD_SPEED_M_S = 1.0


def off_road_plan(step: MissionStep, start_xy: tuple[float, float], plan_id: str, revision: int) -> tuple[RoutePlan, RouteSegmentDescription]:
    """Return the route plan and the one cross-country segment of off-road `step` from `start_xy` [m]."""
    dest = step.destination
    assert dest.off_road and dest.xy is not None, "an off-road step has a point for destination"
    start = (float(start_xy[0]), float(start_xy[1]))
    goal = (float(dest.xy[0]), float(dest.xy[1]))
    length = math.hypot(goal[0] - start[0], goal[1] - start[1])
    line = (start, goal) if length > 1e-3 else (start, (start[0] + 1e-3, start[1]))
    speed = OFF_ROAD_SPEED_M_S if step.constraints.speed_limit is None else min(step.constraints.speed_limit, OFF_ROAD_SPEED_M_S)
    seg = RouteSegmentDescription(
        segment_id=f"{plan_id}.0", plan_id=plan_id, segment_index=0, mode="cross-country", path_object_ids=(),
        centreline=line, width_m=OFF_ROAD_CORRIDOR_M, length_m=length,
        exit=exit_condition(line, OFF_ROAD_CORRIDOR_M, arrival=True),
        constraints=DrivingConstraints(speed_limit=speed, stop_at_exit=True),
    )
    plan = RoutePlan(plan_id=plan_id, mission_id=step.mission_id, step_index=step.step_index, revision=revision, node_ids=(),
                     edge_ids=(), segment_count=1, length_m=length, cost=length, polyline=line, start_xy=start, goal_xy=goal)
    return plan, seg
