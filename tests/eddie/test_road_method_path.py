"""Issue 13: each road follower's output becomes a path in `local` (EDDIE) and a road region (PERCEPTION).

A road seen off-centre gives a path toward it: the frame conversion is checked with a capture pose
that is not the identity and a vehicle that moved since the capture.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

from eddie.modules.errors import NoRoadPath
from eddie.road_following.road_following import RoadFollowingConfig, follower_path, map_road_at, road_line_fix, route_lane_offset
from modules.road_following import (CameraRoadFollower, NoRoadSeen, RoadObservation, cross_section, drive_line, motion_between,
                                    road_region, steering_arc)
from wire.mapfile import PathEdge
from wire.se2 import compose

#: the capture pose in `local` (x, y [m], yaw [rad]): not the identity, so a missing transform shows
AT_CAPTURE = (10.0, -4.0, math.radians(30.0))
CFG = RoadFollowingConfig(lookahead_m=12.0, min_path_m=1.5)


def _in_local(xy_vehicle: tuple[float, float], pose: tuple[float, float, float] = AT_CAPTURE) -> np.ndarray:
    return compose(np.asarray(pose), np.array([xy_vehicle[0], xy_vehicle[1], 0.0]))[:2]


def _road(method: str, lateral: float, heading_deg: float = 0.0, curvature: float = 0.0) -> RoadObservation:
    return RoadObservation(method=method, found=True, lateral_offset_m=lateral, heading_rad=math.radians(heading_deg),
                           road_curvature_per_m=curvature, confidence=0.9, ms_per_frame=1.0)


@pytest.mark.parametrize("method", ["scarf", "yarf"])
def test_a_road_seen_to_the_left_gives_a_path_toward_it_in_local(method: str) -> None:
    obs = _road(method, lateral=2.0)  # road centre 2 m left of the vehicle, parallel
    route = np.array([_in_local((x, 2.0)) for x in (-5.0, 40.0)])  # the route runs along that road
    path = follower_path(obs, AT_CAPTURE, AT_CAPTURE, route, CFG)
    # the path starts at the vehicle and ends on the road seen, 2 m to the vehicle's left — in `local`
    assert np.allclose(path[0], AT_CAPTURE[:2])
    end_v = path[-1] - np.asarray(AT_CAPTURE[:2])
    c, s = math.cos(AT_CAPTURE[2]), math.sin(AT_CAPTURE[2])
    ahead, left = c * end_v[0] + s * end_v[1], -s * end_v[0] + c * end_v[1]
    assert left == pytest.approx(2.0, abs=1e-6) and ahead > CFG.lookahead_m
    # keep-right: the lane 1.9 m right of the centre seen is 0.1 m left of the vehicle
    lane = follower_path(obs, AT_CAPTURE, AT_CAPTURE, route, CFG, lane_offset_m=-1.9)
    end_v = lane[-1] - np.asarray(AT_CAPTURE[:2])
    assert -s * end_v[0] + c * end_v[1] == pytest.approx(0.1, abs=1e-6)


def test_the_path_follows_the_road_seen_at_capture_after_the_vehicle_moved() -> None:
    obs = _road("yarf", lateral=-1.0, heading_deg=10.0)
    now = tuple(compose(np.asarray(AT_CAPTURE), np.array([3.0, 0.2, 0.05])))  # 3 m on since the capture
    route = np.array([_in_local((x, -1.0 + math.tan(math.radians(10)) * x)) for x in (-5.0, 40.0)])
    path = follower_path(obs, AT_CAPTURE, now, route, CFG)
    assert np.allclose(path[0], now[:2])
    # every later point lies on the road centre seen at capture (moved into `local` with the capture pose)
    centre = [_in_local((x, -1.0 + math.tan(math.radians(10)) * x)) for x in (0.0, 40.0)]
    d = np.asarray(centre[1]) - centre[0]
    n = np.array([-d[1], d[0]]) / np.linalg.norm(d)
    assert np.abs((path[1:] - centre[0]) @ n).max() < 1e-6
    # and none lies behind the vehicle now
    back = (path[1:] - np.asarray(now[:2])) @ np.array([math.cos(now[2]), math.sin(now[2])])
    assert back.min() > 0.0


def test_alvinn_drives_its_arc_and_a_left_arc_turns_left() -> None:
    obs = RoadObservation(method="alvinn", found=True, steering_curvature_per_m=0.05, road_point=(12.0, 3.6), confidence=0.8,
                          ms_per_frame=1.0)
    arc = drive_line(obs, length_m=12.0)
    assert np.allclose(arc[0], 0.0) and arc[-1, 1] > 3.0  # 12 m of a 20 m radius arc: 3.5 m to the left
    assert np.allclose(np.hypot(arc[:, 0], arc[:, 1] - 20.0), 20.0)  # on the circle of radius 1/k about (0, 20)
    route = np.array([_in_local(tuple(p)) for p in steering_arc(0.05, 40.0)])
    path = follower_path(obs, AT_CAPTURE, AT_CAPTURE, route, CFG)
    end_v = compose(np.array([0.0, 0.0, -AT_CAPTURE[2]]), np.r_[path[-1] - AT_CAPTURE[:2], 0.0])
    assert end_v[1] > 3.0
    straight = drive_line(obs.model_copy(update={"steering_curvature_per_m": 0.0}), length_m=12.0)
    assert np.allclose(straight[:, 1], 0.0)


def test_no_road_or_a_road_far_off_the_route_is_no_path() -> None:
    lost = RoadObservation(method="scarf", found=False, lateral_offset_m=0.0, heading_rad=0.0, confidence=0.1, ms_per_frame=1.0)
    route = np.array([_in_local((x, 0.0)) for x in (-5.0, 40.0)])
    with pytest.raises(NoRoadPath):
        follower_path(lost, AT_CAPTURE, AT_CAPTURE, route, CFG)
    with pytest.raises(NoRoadSeen):
        road_region(lost, half_width_m=3.0)
    # SCARF locked on a road 6 m to the left while the route goes straight on: not followed
    with pytest.raises(NoRoadPath, match="off the route"):
        follower_path(_road("scarf", lateral=6.0), AT_CAPTURE, AT_CAPTURE, route, CFG)


def test_road_region_is_the_road_seen_widened_and_the_arc_corridor() -> None:
    region = road_region(_road("scarf", lateral=1.5, heading_deg=-5.0), half_width_m=3.0, near_m=1.0, far_m=20.0)
    y10 = 1.5 + math.tan(math.radians(-5.0)) * 10.0
    assert region.contains(Point(10.0, y10 + 2.9)) and region.contains(Point(10.0, y10 - 2.9))
    assert not region.contains(Point(10.0, y10 + 3.2)) and not region.contains(Point(10.0, y10 - 3.2))
    assert not region.contains(Point(0.5, 1.5)) and not region.contains(Point(21.0, y10))
    corridor = road_region(RoadObservation(method="alvinn", found=True, steering_curvature_per_m=-0.04, confidence=0.8,
                                           ms_per_frame=1.0), half_width_m=1.5)
    p = steering_arc(-0.04, 15.0)[-1]
    assert corridor.contains(Point(*p)) and p[1] < -3.0 and not corridor.contains(Point(p[0], p[1] + 2.0))


def test_map_road_lane_offset_and_line_fix_place_the_vehicle_across_the_road() -> None:
    edges = [PathEdge(id="e", from_node="a", to_node="b", mode="follow-road", width=7.6, coords=((0.0, 0.0), (100.0, 0.0)))]
    road = map_road_at(edges, (40.0, -1.0), math.pi)  # driving west: the road's direction is west
    assert road is not None and (road.x, road.y, road.width_m) == (40.0, 0.0, 7.6)
    assert abs(math.remainder(road.direction_rad - math.pi, 2 * math.pi)) < 1e-9
    # a keep-right route driving west runs north of the centre line (+y): 1.9 m right of travel
    route = np.array([(100.0, 1.9), (0.0, 1.9)])
    assert route_lane_offset(route, road) == pytest.approx(-1.9)
    # the road centre seen 1.9 m to the left (vehicle in the right lane), 3° off: the vehicle is on y = 1.9
    obs = _road("yarf", lateral=1.9, heading_deg=3.0)
    fix = road_line_fix(obs, road, (5.0, 6.0, 0.1), stamp=12.5)
    assert fix is not None and fix.y == pytest.approx(1.9 * math.cos(math.radians(3.0)))
    assert math.remainder(fix.angle - math.pi, 2 * math.pi) == pytest.approx(0.0)
    assert math.remainder(fix.yaw - (math.pi - math.radians(3.0)), 2 * math.pi) == pytest.approx(0.0)
    assert fix.local is not None and fix.local.x == 5.0 and fix.stamp == 12.5
    assert road_line_fix(obs.model_copy(update={"method": "alvinn"}), road, (0, 0, 0), 0.0) is None


def test_cross_section_and_motion_between_frames() -> None:
    road = Polygon([(0, -3.8), (100, -3.8), (100, 3.8), (0, 3.8)])
    off, width = cross_section(road, (50.0, -1.9, 0.0))
    assert off == pytest.approx(-1.9) and width == pytest.approx(7.6)
    off, width = cross_section(road, (50.0, -1.9, math.pi))  # facing west the same spot is 1.9 m left
    assert off == pytest.approx(1.9)
    assert cross_section(road, (150.0, 0.0, 0.0)) is None  # the cut misses the road
    m = motion_between((1.0, 1.0, math.pi / 2), (1.0, 3.0, math.pi / 2 + 0.1))
    assert (m.dx, m.dy, m.dyaw) == pytest.approx((2.0, 0.0, 0.1))


def test_an_alvinn_follower_needs_weights() -> None:
    from modules.road_following import AlvinnModelError, load_alvinn_weights

    with pytest.raises(AlvinnModelError, match="--alvinn-weights"):
        CameraRoadFollower("alvinn")
    with pytest.raises(AlvinnModelError, match="no such file"):
        load_alvinn_weights("/nonexistent/alvinn.npz")
    with pytest.raises(ValueError, match="not one of"):
        CameraRoadFollower("perception")


def test_a_keep_right_step_also_counts_its_goal_in_the_lane_reached() -> None:
    from eddie.mission_service.mission_progress import MissionProgress, step_goals
    from modules.captain.missionfile import load_mission
    from modules.map_navigator import load_map
    from vehicle_sim.worldfile import WORLDS_DIR

    m = load_map("schenley")
    mission = load_mission(WORLDS_DIR / "schenley-drive.yaml").model_copy(update={"mission_id": "lane-1"})
    (g,) = step_goals(m, (m.world.start.x, m.world.start.y), mission)
    assert g.lane_goal is not None and math.dist(g.lane_goal, g.goal) == pytest.approx(7.6 / 4.0)
    assert g.lane_goal[0] > g.goal[0] + 1.8  # driving north on Tee Dr, the right lane is east of the centre
    for at, reached in ((g.lane_goal, True), ((g.goal[0] - 1.9, g.goal[1]), False)):  # the left lane is not the goal
        prog = MissionProgress(mission, [g], submitted_at=0.0)
        prog.start(0.0)
        prog.update(1.0, at)
        assert (prog.arrival is not None) is reached, prog.status
        prog.update(2.0, at)  # standing there: at rest, the arrival is claimed
        assert (prog.status.state == "succeeded") is reached, prog.status


def test_a_road_that_jumps_between_frames_is_no_road_until_it_stays() -> None:
    from modules.road_following import CameraRoadFollower

    f = CameraRoadFollower("scarf", max_jump_m=0.8, max_rejects=2)
    pose0, pose1 = (0.0, 0.0, 0.0), (2.0, 0.0, 0.0)
    assert f._gate(_road("scarf", lateral=1.5), pose0).found
    assert f._gate(_road("scarf", lateral=1.4), pose1).found  # 0.1 m: the same road
    jumped = _road("scarf", lateral=-0.1, heading_deg=6.0)  # a driveway pulled the triangle 1.5 m over
    assert not f._gate(jumped, pose1).found and not f._gate(jumped, pose1).found
    assert f._gate(jumped, pose1).found  # the third frame in a row: the road did move


def test_the_path_stops_at_the_routes_end_where_the_road_goes_on() -> None:
    obs = _road("yarf", lateral=0.0)  # the road runs straight on, the route ends 6 m ahead of the vehicle
    route = np.array([_in_local((x, 0.0)) for x in (-5.0, 6.0)])
    path = follower_path(obs, AT_CAPTURE, AT_CAPTURE, route, CFG, lane_offset_m=-1.9, max_off_route_m=5.4)
    ahead = (path - np.asarray(AT_CAPTURE[:2])) @ np.array([math.cos(AT_CAPTURE[2]), math.sin(AT_CAPTURE[2])])
    assert len(path) >= 2 and ahead.max() <= 6.0 and ahead.max() > 4.0, ahead
    # at the route's end nothing is left to follow: no path (the last one ends there)
    with pytest.raises(NoRoadPath, match="past the route's end"):
        follower_path(obs, AT_CAPTURE, AT_CAPTURE, np.array([_in_local((x, 0.0)) for x in (-5.0, 0.5)]), CFG)
