"""Vision road following's core: the road seen at capture, in `local`, and a path along the route inside it.

Seed: Navlab 1990 §2.5 / ch. 3 — the vision module sees the road, plans in the controller's `local`
frame (which never jumps) and sends the path to the controller; a trigger wakes it after an
intersection. The segmentation is PERCEPTION's (`modules.perception.PerceptionPipeline`), the path
planner the PILOT's (`modules.pilot.LocalPathPlanner`); this file only changes frames and picks the
goal: the farthest route point inside the road region within the look-ahead.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from shapely import affinity
from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from eddie.modules.errors import NoRoadPath
from modules.pilot import LocalPathPlanner, PlanningError
from wire.se2 import transform_points

__all__ = ["RoadFollowingConfig", "RoadPath", "region_in_local", "route_goal", "plan_road_path", "route_to_local", "route_ahead"]


class RoadFollowingConfig(BaseModel):
    """Vision road following settings: look-ahead [m], road margin [m], shortest useful path [m], speed [m/s]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    lookahead_m: float = Field(12.0, gt=0.0, description="goal at most this far along the route [m]")
    margin_m: float = Field(0.4, ge=0.0, description="the region is shrunk by this margin before planning [m]")
    approach_half_width_m: float = Field(0.8, gt=0.0, description="half width of the corridor from the vehicle to the road seen [m]")
    min_path_m: float = Field(1.5, gt=0.0, description="a goal closer than this along the route is no path [m]")
    speed_mps: float = Field(1.0, gt=0.0, description="speed the path is driven at [m/s]")
    blind_speed_mps: float = Field(0.5, gt=0.0, description="speed along the route when vision sees no road [m/s] (the seed's intersections)")
    end_reach_m: float = Field(1.5, ge=0.0, description="the route's end (the mission's goal, e.g. a mailbox at the kerb) is the goal when this near the road seen [m]")


class RoadPath(BaseModel):
    """A path for the controller: poses (x [m], y [m], yaw [rad]) in `local`, the capture it came from.

    `sensed_at` [s] sim is the capture's stamp, so sense-to-act latency is measurable at the controller.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    poses: tuple[tuple[float, float, float], ...] = Field(min_length=2)
    speed_mps: float = Field(gt=0.0)
    sensed_at: float


def region_in_local(road_vehicle: BaseGeometry, local_from_vehicle: tuple[float, float, float]) -> BaseGeometry:
    """Return the road region seen in the `vehicle` frame at capture, moved into `local` by the pose then."""
    x, y, yaw = local_from_vehicle
    c, s = math.cos(yaw), math.sin(yaw)
    return affinity.affine_transform(road_vehicle, [c, -s, s, c, x, y])


def route_goal(route_local: np.ndarray, region: BaseGeometry, start_xy: np.ndarray, cfg: RoadFollowingConfig) -> tuple[float, float, float]:
    """Return the goal pose in `local`: the farthest route point inside `region` within the look-ahead of `start_xy`.

    The route's end, when within the look-ahead and `end_reach_m` of the region, is the goal even
    outside it (the mission's goal may lie at the road's edge).

    `route_local` (N, 2) [m] is the route in `local`; the search starts `min_path_m` past the route
    point nearest the start and walks forward in 0.25 m steps (the sensor sees the road only some
    metres ahead, so points before the first one inside are passed over); the heading is the
    route's there. Raise NoRoadPath when no route point within the look-ahead lies on the road.
    """
    line = LineString(np.asarray(route_local, dtype=np.float64))
    s0 = line.project(Point(float(start_xy[0]), float(start_xy[1])))
    best = None
    s = s0 + cfg.min_path_m
    end = min(line.length, s0 + cfg.lookahead_m)
    while s <= end + 1e-9:
        p = line.interpolate(s)
        if region.contains(p):
            best = s
        elif best is not None:
            break  # the route left the road seen: the goal is the last point on it
        s += 0.25
    if best is not None and best < line.length and line.length <= end + 1e-9 \
            and region.distance(line.interpolate(line.length)) <= cfg.end_reach_m:
        # the goal itself may lie at the road's edge (a mailbox at the kerb): drive to it, not to the
        # last route point inside the shrunken road, which stops the vehicle short of its goal
        best = line.length
    if best is None:
        raise NoRoadPath(f"the route leaves the seen road within {cfg.min_path_m:.1f} m of the vehicle")
    a, b = line.interpolate(max(best - 0.5, 0.0)), line.interpolate(min(best + 0.5, line.length))
    p = line.interpolate(best)
    return float(p.x), float(p.y), math.atan2(b.y - a.y, b.x - a.x)


def plan_road_path(planner: LocalPathPlanner, start_local: tuple[float, float, float], road_vehicle: BaseGeometry,
                   local_from_vehicle: tuple[float, float, float], route_local: np.ndarray, sensed_at: float,
                   cfg: RoadFollowingConfig = RoadFollowingConfig()) -> RoadPath:
    """Plan from the vehicle's pose now (`local`) along the route through the road seen at capture; raise NoRoadPath."""
    region = region_in_local(road_vehicle, local_from_vehicle)
    if cfg.margin_m > 0:
        region = region.buffer(-cfg.margin_m)
    if region.is_empty:
        raise NoRoadPath("the road seen is narrower than twice the margin")
    goal = route_goal(route_local, region, np.asarray(start_local[:2]), cfg)
    # the road seen begins some metres ahead of the sensor: join the vehicle to it along the route
    line = LineString(np.asarray(route_local, dtype=np.float64))
    s0 = line.project(Point(start_local[0], start_local[1]))
    s1 = line.project(Point(goal[0], goal[1]))
    approach = [(start_local[0], start_local[1])] + [
        (p.x, p.y) for p in (line.interpolate(s) for s in np.arange(s0, s1, 0.5))]
    region = region.union(LineString(approach + [(goal[0], goal[1])]).buffer(cfg.approach_half_width_m))
    try:
        planned = planner.plan(np.asarray(start_local, dtype=np.float64), [np.asarray(goal)], region)
    except PlanningError as exc:
        raise NoRoadPath(f"no path through the road seen: {exc}") from None
    poses = tuple((float(p[0]), float(p[1]), float(p[2])) for p in planned.poses)
    return RoadPath(poses=poses, speed_mps=cfg.speed_mps, sensed_at=sensed_at)


def route_ahead(route_local: np.ndarray, start_xy: np.ndarray, length_m: float, step_m: float = 0.5) -> np.ndarray:
    """Return the route (M, 2) [m] from the point nearest `start_xy` on for `length_m` [m]: the path to dead-reckon when vision sees no road."""
    line = LineString(np.asarray(route_local, dtype=np.float64))
    s0 = line.project(Point(float(start_xy[0]), float(start_xy[1])))
    s = np.append(np.arange(s0, min(s0 + length_m, line.length), step_m), min(s0 + length_m, line.length))
    return np.array([[line.interpolate(v).x, line.interpolate(v).y] for v in s])


def route_to_local(route_world: np.ndarray, local_from_world: tuple[float, float, float]) -> np.ndarray:
    """Return a route (N, 2) [m] given in `world` in `local`, with `local_from_world` = (world←local)⁻¹."""
    return transform_points(np.asarray(local_from_world, dtype=np.float64), route_world)
