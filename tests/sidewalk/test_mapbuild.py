"""Map building output: the built map is a loadable map file with the built objects; the score counts errors,
spurious and missed objects against truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.perception.object_tracker import TrackedObject
from sidewalk.mapbuild import DISCRETE_KINDS, BuiltMap, score_map, write_map
from vehicle_sim.worldfile import load_world


def _obj(i: int, x: float, y: float, h: float) -> TrackedObject:
    return TrackedObject(id=i, x=x, y=y, cov=((0.04, 0.0), (0.0, 0.04)), confidence=0.9, hits=5, misses=0, moving=False,
                         size=0.4, height=h)


@pytest.fixture(scope="module")
def nh():
    return load_world("north_hills"), load_world("north_hills", kind="map")


def test_built_map_round_trips_and_replaces_the_discrete_objects(nh, tmp_path) -> None:
    world, map_ = nh
    truth = [o for o in world.objects if o.kind == "mailbox"][:3]
    built = BuiltMap(objects=[_obj(1, truth[0].center[0] + 0.3, truth[0].center[1], 1.1),
                              _obj(2, truth[1].center[0], truth[1].center[1] - 0.5, 2.9),
                              _obj(3, 500.0, 500.0, 1.0)],
                     frames=10, distance_m=100.0, dropped_moving=1, dropped_spurious=2, odometry_error_final_m=0.0)
    path = write_map(map_, built, tmp_path / "b.map.geojson")
    back = load_world(path, kind="map")
    discrete = [o for o in back.objects if o.kind in DISCRETE_KINDS]
    assert len(discrete) == 3
    assert sorted(o.kind for o in discrete) == ["mailbox", "mailbox", "tree"]
    assert len(back.edges) == len(map_.edges) and back.start == map_.start
    route = np.array([[truth[0].center[0], truth[0].center[1] - 5], [truth[0].center[0], truth[0].center[1] + 5]])
    sc = score_map(world, built, route)
    assert sc["matched"] == 2 and sc["spurious"] == 1
    assert sc["error_mean_m"] == pytest.approx(0.4, abs=1e-3) and sc["error_max_m"] == pytest.approx(0.5, abs=1e-3)
    near = sum(1 for o in world.objects if o.kind in DISCRETE_KINDS and o.center is not None
               and abs(o.center[0] - truth[0].center[0]) <= 10.0 and abs(o.center[1] - truth[0].center[1]) <= 15.0)
    assert sc["missed"] <= near - 1


def test_turn_anchors_take_out_the_odometry_scale_error() -> None:
    from sidewalk.mapbuild import anchored_distance, turn_anchors

    # the lane: 100 m east, 100 m north, 100 m east; the vehicle rounds each corner on a 7 m arc (left,
    # then right); odometry reads every length 1 % long
    lane = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [200.0, 100.0]])
    r, scale, arc = 7.0, 1.01, 7.0 * np.pi / 2
    legs = [("straight", 93.0), ("arc", 1.0), ("straight", 86.0), ("arc", -1.0), ("straight", 93.0)]
    rows, d, yaw = [], 0.0, 0.0
    for kind, v in legs:
        n = int(round((arc if kind == "arc" else v) / 0.1))
        for _ in range(n):
            rows.append((scale * d, yaw))
            d += 0.1
            if kind == "arc":
                yaw += v * 0.1 / r
    anchors = turn_anchors(lane, np.array(rows))
    assert len(anchors) == 3
    # on the northbound leg, at (100, y): the vehicle has driven 93 + arc + (y − 7) m, the lane is at 100 + y;
    # near a turn the cut corner (1.5 m each side of its middle, spread over the leg) is left
    for y, tol in ((20.0, 1.1), (50.0, 0.3), (80.0, 1.1)):
        odo = scale * (93.0 + arc + y - 7.0)
        assert anchored_distance(anchors, odo) == pytest.approx(100.0 + y, abs=tol)
    assert abs(scale * (93.0 + arc + 43.0) - 150.0) > 1.0  # raw odometry is off by more mid-leg
    assert anchored_distance(anchors, scale * 50.0) == pytest.approx(50.0, abs=1.0)  # before the first turn, stretched
    # no turn in the odometry where the lane has two: the raw distance
    straight = np.array([(scale * k, 0.0) for k in np.arange(0.0, 300.0, 0.1)])
    assert len(turn_anchors(lane, straight)) == 1


@pytest.mark.timeout(300)  # ~40 s beside three lock-step runs (load ~8 on 2 cores): 80 m of simulated drive, a laser image every 4 m
def test_the_mapping_drive_steers_by_the_robots_estimate_never_the_truth(nh, tmp_path) -> None:
    from modules.captain.missionfile import load_mission
    from sidewalk.mapbuild import END_SHORT_M, SimulatedVehicle, drive_route, route_lane, route_polyline
    from vehicle_sim.mapgen import MapError, derive_map
    from vehicle_sim.odometry import PERFECT_ODOMETRY

    world, _ = nh
    # the robot's map puts everything 2 m east of the truth, its start too: with perfect odometry and no fix, a drive
    # by the robot's estimate ends 2 m west of where the robot believes it is (on its map's lane); a drive by the
    # truth would end on the map's lane
    wrong = derive_map(world, MapError(offset_x=2.0), np.random.default_rng(0))
    (tmp_path / "hop.yaml").write_text("mission: hop\nworld: north_hills\nvehicle: navlab\nsteps:\n"
                                       "  - {destination: {x: 0, y: 40}, constraints: [keep_right]}\n")
    lane = route_lane(route_polyline(wrong, load_mission(tmp_path / "hop.yaml")), 1.5)
    car = SimulatedVehicle(world, vehicle="navlab", odometry=PERFECT_ODOMETRY)
    assert car.true_xy() == pytest.approx((world.start.x, world.start.y))
    log = drive_route(car, lane, (wrong.start.x, wrong.start.y, wrong.start.yaw), vehicle="navlab", step_m=4.0)
    assert log.arrived and log.perception_fixes == log.landmark_fixes == 0 and len(log.shots) > 15
    end = lane[-1]
    assert math.dist(log.estimate[:2], end) == pytest.approx(END_SHORT_M, abs=0.5)  # it believes it stopped at the end
    true_end = car.true_xy()
    assert true_end == pytest.approx((log.estimate[0] - 2.0, log.estimate[1]), abs=0.3)  # it is where its belief puts it
    assert math.dist(true_end, end) > 1.8  # not at the map lane's end, where the truth would have steered it
