"""Map building output: the built map is a loadable map file with the built objects; the score counts errors,
spurious and missed objects against truth."""

from __future__ import annotations

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


def test_turn_anchors_take_out_the_odometry_scale_error_and_the_cut_corner() -> None:
    from sidewalk.mapbuild import anchored_distance, turn_anchors

    # the lane: 100 m east, then north; the vehicle drives the corner as a 7 m arc; odometry reads 1 % long
    lane = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0]])
    r, scale = 7.0, 1.01
    rows, true_d = [], []
    for d in np.arange(0.0, 93.0 + r * np.pi / 2 + 90.0, 0.1):
        if d < 93.0:
            yaw = 0.0
        elif d < 93.0 + r * np.pi / 2:
            yaw = (d - 93.0) / r
        else:
            yaw = np.pi / 2
        rows.append((scale * d, yaw))
        true_d.append(d)
    anchors = turn_anchors(lane, np.array(rows))
    assert len(anchors) == 3
    after = 93.0 + r * np.pi / 2  # where the arc meets the northbound lane, (100, 7)
    for y in (10.0, 50.0, 90.0):  # on the northbound straight: lane arc length 100 + y
        odo = scale * (after + y - 7.0)
        assert anchored_distance(anchors, odo) == pytest.approx(100.0 + y, abs=0.3)
        assert abs(odo - (100.0 + y)) > 0.5  # raw odometry is off by more
    assert anchored_distance(anchors, scale * 50.0) == pytest.approx(50.0, abs=0.3)  # before the turn, stretched
