"""EDDIE's module cores on real simulator frames: obstacle stop, vision road following, landmark matching."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

from eddie.landmark_matching import landmark_fix
from eddie.modules import NoRoadPath
from eddie.obstacle_stop import ObstacleStopConfig, obstacle_ahead
from eddie.road_following import RoadFollowingConfig, plan_road_path, route_goal, route_to_local
from modules.perception import PerceptionPipeline
from modules.perception.obstacles import LaserScan
from modules.pilot import LocalPathPlanner, PlannerConfig
from sidewalk.cli._perception import FrameSource, objects_in_view
from wire.se2 import compose, inverse, transform_points

#: on the campus's west walk, looking north along it (x = 0 is its centreline)
ON_WALK = (0.0, -24.0, math.pi / 2)
#: an arbitrary `local` frame: world ← local
WORLD_FROM_LOCAL = np.array([37.0, -12.0, math.radians(-65.0)])


@pytest.fixture(scope="module")
def src() -> FrameSource:
    return FrameSource("campus", vehicle="terregator", seed=1, use_map=False)


def _img(src: FrameSource, pose, seed=0):
    img, _labels, _dt = src.capture(pose, 1.0, np.random.default_rng(seed))
    return img


def _tree(src: FrameSource):
    return next(o for o in src.world.objects if o.kind == "tree" and o.center is not None)


def _scan(src: FrameSource, pose, seed=0) -> LaserScan:
    _img(src, pose, seed)
    return LaserScan.from_capture(src.last_frame)


def test_obstacle_stop_sees_a_tree_on_the_path_and_not_the_open_walk(src: FrameSource) -> None:
    cfg = ObstacleStopConfig(stop_distance_m=5.0)
    clear = obstacle_ahead(_scan(src, ON_WALK), cfg)
    assert not clear.blocked, clear
    tx, ty = _tree(src).center
    facing = (tx - 3.5, ty, 0.0)  # 3.5 m west of the trunk, looking east at it
    # no path: the vehicle rolls to rest straight ahead; at 2 m/s it needs 1.1 + 0.5 + 1 + 2 m, so the trunk stops it
    hit = obstacle_ahead(_scan(src, facing), cfg, speed=2.0)
    assert hit.blocked and hit.distance_m is not None
    assert 2.0 < hit.distance_m < 3.6  # the near side of the trunk
    assert not obstacle_ahead(_scan(src, (tx - 3.5, ty, math.pi)), cfg, speed=2.0).blocked  # the same place, looking away
    # no path and at rest (between two paths), the trunk beyond its clearance does not hold it: the next path is judged
    rest = obstacle_ahead(_scan(src, facing), cfg)
    assert rest.distance_m is not None and not rest.blocked
    # the same view, but the path (in an arbitrary `local`) swerves left past the trunk: nothing on it
    local_from_world = inverse(WORLD_FROM_LOCAL)
    pose_local = compose(local_from_world, np.asarray(facing))
    swerve = transform_points(local_from_world, np.array([[tx - 3.5, ty], [tx - 2.5, ty + 2.5], [tx + 2.0, ty + 4.0]]))
    assert not obstacle_ahead(_scan(src, facing), cfg, path_local=swerve, pose_local=tuple(pose_local)).blocked


def test_obstacle_stop_ignores_an_obstacle_past_the_end_of_the_commanded_path(src: FrameSource) -> None:
    cfg = ObstacleStopConfig(stop_distance_m=8.0)  # a Terregator's front 1.1 m, 0.5 m clearance, 1 m/s² braking
    tx, ty = _tree(src).center
    local_from_world = inverse(WORLD_FROM_LOCAL)

    def seen(x_from_trunk: float, path_end_from_trunk: float, speed: float):
        facing = (tx - x_from_trunk, ty, 0.0)  # west of the trunk, looking east at it
        path = transform_points(local_from_world, np.array([[tx - x_from_trunk, ty], [tx - path_end_from_trunk, ty]]))
        return obstacle_ahead(_scan(src, facing), cfg, path_local=path, pose_local=tuple(compose(local_from_world, np.asarray(facing))),
                              speed=speed)

    # past the trunk: on the path, a stop at once (8 m)
    hit = seen(6.0, -3.0, 1.0)
    assert hit.blocked and 4.0 < hit.distance_m < 6.0
    # the path ends 4.5 m short: the front stops far from it, near or not
    assert not seen(6.0, 4.5, 1.0).blocked and not seen(5.0, 4.5, 0.0).blocked
    # the path ends 1 m short, so the front (1.1 m) would touch it: drive on while far, stop once near
    far = seen(6.0, 1.0, 1.0)
    assert far.distance_m is not None and not far.blocked
    near = seen(2.6, 1.0, 1.0)  # trunk ≈ 2.3 m ahead: the 0.5 m clearance, 0.5 s latency and 0.5 m braking at 1 m/s
    assert near.blocked and near.distance_m < 2.6
    assert not seen(2.6, 1.0, 0.0).blocked  # at rest there: it may creep on to its clearance
    assert seen(1.5, 1.0, 0.0).blocked


def test_road_following_plans_in_local_along_the_route_inside_the_walk(src: FrameSource) -> None:
    img = _img(src, ON_WALK)
    objs = tuple(o for o in objects_in_view(src, ON_WALK) if o.shape.type == "flat")
    out = PerceptionPipeline(src.table).process(img, objs, ON_WALK, error_allowance=0.5)
    assert out.navigable is not None
    local_from_world = inverse(WORLD_FROM_LOCAL)
    at_capture = compose(local_from_world, np.asarray(ON_WALK))  # the controller's `local` pose then
    now = compose(local_from_world, np.array([0.0, -23.5, math.pi / 2]))  # it moved on 0.5 m while planning
    route = route_to_local(np.array([[0.0, -40.0], [0.0, 0.0]]), tuple(local_from_world))
    planner = LocalPathPlanner(PlannerConfig(kind="se2"), seed=3)
    path = plan_road_path(planner, tuple(now), out.navigable, tuple(at_capture), route, sensed_at=img.stamp,
                          cfg=RoadFollowingConfig(lookahead_m=8.0))
    assert path.sensed_at == img.stamp
    world = transform_points(WORLD_FROM_LOCAL, np.array([p[:2] for p in path.poses]))
    assert np.abs(world[:, 0]).max() < 1.5  # inside the 3 m walk
    assert world[-1, 1] > -23.5 + 4.0  # it gets somewhere along the route
    assert world[-1, 1] <= -23.5 + 8.0 + 0.3


def test_road_following_refuses_a_route_off_the_road() -> None:
    region = Polygon([(0, -1.5), (20, -1.5), (20, 1.5), (0, 1.5)])
    across = np.array([[0.0, 0.0], [0.0, 30.0]])  # the route turns off the road at once
    with pytest.raises(NoRoadPath):
        route_goal(across, region, np.array([0.0, 0.0]), RoadFollowingConfig())
    along = np.array([[0.0, 0.0], [40.0, 0.0]])
    g = route_goal(along, region, np.array([0.0, 0.0]), RoadFollowingConfig(lookahead_m=30.0))
    assert region.contains(Point(g[0], g[1])) and g[0] > 19.0 and abs(g[2]) < 1e-9


def test_a_goal_at_the_roads_edge_is_driven_to_and_one_far_off_the_road_is_not() -> None:
    region = Polygon([(-5.0, -1.5), (60.0, -1.5), (60.0, 1.5), (-5.0, 1.5)])  # a 3 m road along x
    cfg = RoadFollowingConfig(lookahead_m=30.0)
    kerb = np.array([[0.0, 0.0], [20.0, 0.0], [22.0, 2.5]])  # ends 1 m beside the road (a mailbox at the kerb)
    g = route_goal(kerb, region, np.array([0.0, 0.0]), cfg)
    assert (g[0], g[1]) == pytest.approx((22.0, 2.5))
    field = np.array([[0.0, 0.0], [20.0, 0.0], [22.0, 6.0]])  # ends 4.5 m off the road: the last point on it
    g = route_goal(field, region, np.array([0.0, 0.0]), cfg)
    assert region.contains(Point(g[0], g[1])) and g[0] < 21.0
    far = np.array([[0.0, 0.0], [50.0, 0.0], [52.0, 2.5]])  # the end beyond the look-ahead: not yet
    g = route_goal(far, region, np.array([0.0, 0.0]), cfg)
    assert region.contains(Point(g[0], g[1])) and g[0] < 31.0


def test_landmark_matching_fixes_the_position_across_the_walk(src: FrameSource) -> None:
    img = _img(src, ON_WALK)
    objs = tuple(o for o in objects_in_view(src, ON_WALK) if o.shape.type == "flat")
    prior = (ON_WALK[0] + 0.4, ON_WALK[1] - 0.3, ON_WALK[2] + math.radians(2.0))
    fix, why = landmark_fix(PerceptionPipeline(src.table), img, objs, prior)
    assert fix is not None, why
    assert abs(fix.x - ON_WALK[0]) < 0.15 < abs(prior[0] - ON_WALK[0])  # across the walk the fix is exact
    assert fix.stamp == img.stamp and len(fix.covariance) == 9


def test_route_ahead_is_the_route_from_the_vehicle_on() -> None:
    from eddie.road_following.road_following import route_ahead

    route = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    ahead = route_ahead(route, np.array([4.0, 0.3]), 8.0)
    assert ahead[0] == pytest.approx([4.0, 0.0]) and ahead[-1] == pytest.approx([10.0, 2.0])
    assert len(route_ahead(route, np.array([10.0, 10.0]), 8.0)) < 2 + 1  # at the end: nothing left to drive
