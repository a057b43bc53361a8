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

from eddie.messages.navigator import LineFixMessage, LocalPose
from eddie.modules.errors import NoRoadPath
from modules.road_following import RoadObservation
from modules.road_following.road_seen import NoRoadSeen, drive_line
from modules.pilot import LocalPathPlanner, PlanningError
from wire.se2 import inverse, transform_points, wrap_angle

__all__ = ["RoadFollowingConfig", "RoadPath", "region_in_local", "route_goal", "plan_road_path", "route_to_local", "route_ahead",
           "MapRoad", "map_road_at", "route_lane_offset", "follower_path", "road_line_fix"]


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


# ---- the road followers' road (issue 13): SCARF/YARF's centre line, ALVINN's arc, and the map's road ----

class MapRoad(BaseModel):
    """The map's road centre near a pose: nearest point (x, y) [m] `world`, direction of travel [rad], width [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    x: float
    y: float
    direction_rad: float
    width_m: float


def map_road_at(edges, xy: tuple[float, float], yaw: float) -> MapRoad | None:
    """Return the map road (path edges: `.coords` `world`, `.width`) nearest `xy`, its direction the one nearer `yaw` [rad]."""
    p = Point(float(xy[0]), float(xy[1]))
    best = None
    for e in edges:
        if len(e.coords) < 2:
            continue
        line = LineString(e.coords)
        d = line.distance(p)
        if best is None or d < best[0]:
            best = (d, line, float(e.width))
    if best is None:
        return None
    _, line, width = best
    s = line.project(p)
    q = line.interpolate(s)
    a, b = line.interpolate(max(s - 0.5, 0.0)), line.interpolate(min(s + 0.5, line.length))
    th = math.atan2(b.y - a.y, b.x - a.x)
    if math.cos(th - yaw) < 0.0:
        th = wrap_angle(th + math.pi)
    return MapRoad(x=float(q.x), y=float(q.y), direction_rad=th, width_m=width)


def route_lane_offset(route_world: np.ndarray, road: MapRoad) -> float:
    """Return how far [m] the route runs left (+) of the map road's centre at the road point (a keep-right route: negative)."""
    line = LineString(np.asarray(route_world, dtype=np.float64))
    q = line.interpolate(line.project(Point(road.x, road.y)))
    return float(-math.sin(road.direction_rad) * (q.x - road.x) + math.cos(road.direction_rad) * (q.y - road.y))


def follower_path(obs: RoadObservation, at_capture: tuple[float, float, float], now_local: tuple[float, float, float],
                  route_local: np.ndarray, cfg: RoadFollowingConfig, *, lane_offset_m: float = 0.0,
                  max_off_route_m: float = 3.5) -> np.ndarray:
    """Return the path (N, 2) [m] in `local` a follower's road gives: its line to drive, moved by the pose at capture.

    SCARF/YARF: the road centre seen moved `lane_offset_m` [m] left; ALVINN: its steering arc. Points
    the vehicle has passed since the capture are dropped, and so are points past the route's end (the
    road goes on beyond the goal; the path stops there); the path starts at the vehicle now.
    Raise NoRoadPath when the follower saw no road, when the line's end is more than
    `max_off_route_m` [m] from the route (the follower locked on something that is not the road taken),
    or when nothing of it is left before the route's end.
    """
    try:
        # ALVINN's arc is driven as far as its road point (the look-ahead it was trained for), the road seen a little beyond
        line_v = drive_line(obs, lane_offset_m=lane_offset_m, length_m=cfg.lookahead_m + (0.0 if obs.method == "alvinn" else 4.0))
    except NoRoadSeen as exc:
        raise NoRoadPath(str(exc)) from None
    line = transform_points(np.asarray(at_capture, dtype=np.float64), line_v)
    ahead = transform_points(inverse(np.asarray(now_local, dtype=np.float64)), line)[:, 0]
    line = line[ahead > cfg.min_path_m * 0.5]
    if len(line) < 2:
        raise NoRoadPath(f"{obs.method}: the road seen is behind the vehicle now")
    route = LineString(np.asarray(route_local, dtype=np.float64))
    before_end = np.array([route.project(Point(float(x), float(y))) < route.length - 0.05 for x, y in line])
    if not before_end.any():
        raise NoRoadPath(f"{obs.method}: the road seen lies past the route's end")
    line = line[:int(np.argmin(before_end)) if not before_end.all() else len(line)]
    off = route.distance(Point(float(line[-1, 0]), float(line[-1, 1])))
    if off > max_off_route_m:
        raise NoRoadPath(f"{obs.method}: the road seen ends {off:.1f} m off the route (limit {max_off_route_m:.1f} m)")
    return np.vstack([np.asarray(now_local[:2], dtype=np.float64), line])


def road_line_fix(obs: RoadObservation, road: MapRoad, at_capture_local: tuple[float, float, float], stamp: float, *,
                  sigma_cross_m: float = 0.35, sigma_yaw_rad: float = math.radians(2.0), source: str = "road_following") -> LineFixMessage | None:
    """Return the navigator's line fix a road centre seen (SCARF/YARF) gives with the map's road (None for ALVINN or no road).

    The vehicle lies on the line parallel to the map road's centre, as far to its side as the road
    centre seen is to the other side of the vehicle; its yaw is the road's direction minus the
    road heading seen in `vehicle`.
    """
    if obs.method == "alvinn" or not obs.found or obs.lateral_offset_m is None or obs.heading_rad is None:
        return None
    th = road.direction_rad
    d = -obs.lateral_offset_m * math.cos(obs.heading_rad)
    at = LocalPose.from_pose2d(at_capture_local)
    return LineFixMessage(stamp=stamp, x=road.x - d * math.sin(th), y=road.y + d * math.cos(th), angle=th, sigma_cross=sigma_cross_m,
                          yaw=float(wrap_angle(th - obs.heading_rad)), sigma_yaw=sigma_yaw_rad, local=at, source=source)
