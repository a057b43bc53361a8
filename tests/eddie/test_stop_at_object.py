"""Stop at an object: the laser's sighting of the map's object corrects a belief that is off along the road."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddie.obstacle_stop.stop_at_object import ObjectCorrection, ObjectSightingConfig, sight_object
from modules.perception.obstacles import Obstacle

MAILBOX = (-236.64, 128.60)  # north_hills' delivery mailbox, `world`


def _post(xv: float, yv: float, size: float = 0.3, height: float = 1.15) -> Obstacle:
    """A post seen at (xv, yv) in `vehicle` [m]."""
    h = size / 2
    poly = ((xv - h, yv - h), (xv + h, yv - h), (xv + h, yv + h), (xv - h, yv + h))
    return Obstacle(polygon=poly, height=height, centroid=(xv, yv), distance=math.hypot(xv, yv) - h, points=40)


def _seen_from(truth: tuple[float, float, float], xy: tuple[float, float]) -> tuple[float, float]:
    c, s = math.cos(truth[2]), math.sin(truth[2])
    dx, dy = xy[0] - truth[0], xy[1] - truth[1]
    return (c * dx + s * dy, -s * dx + c * dy)


@pytest.mark.parametrize("along", [1.6, -1.2, 0.4])
def test_a_belief_off_along_the_road_is_moved_onto_the_truth_by_the_object_seen(along: float) -> None:
    truth = (-240.0, 136.0, -math.pi / 2)  # driving south on Birch, 7.4 m before the mailbox
    belief = (truth[0], truth[1] - along, truth[2])  # `along` metres ahead (south) of the truth
    s = sight_object([_post(*_seen_from(truth, MAILBOX))], MAILBOX, belief, stamp=3.0)
    assert s is not None and s.range_m == pytest.approx(math.dist(truth[:2], MAILBOX), abs=1e-6)
    corr = ObjectCorrection()
    corr.add(s)
    x, y = corr.corrected(np.array(belief))
    assert math.dist((x, y), truth[:2]) < 1e-6


def test_another_post_and_a_far_one_are_not_taken_for_the_object() -> None:
    truth = (-240.0, 136.0, -math.pi / 2)
    belief = (truth[0], truth[1] - 1.0, truth[2])
    other = _post(*_seen_from(truth, (MAILBOX[0] + 0.5, MAILBOX[1] - 2.0)))  # a post 2 m past the mailbox
    mailbox = _post(*_seen_from(truth, MAILBOX))
    s = sight_object([other, mailbox], MAILBOX, belief, stamp=1.0)
    assert s is not None and math.dist(s.correction, (0.0, 1.0)) < 1e-6
    assert sight_object([other], MAILBOX, belief, stamp=1.0) is None  # 3 m from the prediction: outside the 2.5 m gate
    assert sight_object([_post(20.0, 3.0)], MAILBOX, belief, stamp=1.0) is None  # out of the trusted range
    wide = _post(*_seen_from(truth, MAILBOX), size=2.5)  # a parked car is no post
    assert sight_object([wide], MAILBOX, belief, stamp=1.0) is None


def test_a_correction_beyond_its_bound_is_refused_and_the_median_outvotes_one_bad_sighting() -> None:
    truth = (-240.0, 136.0, -math.pi / 2)
    far_off = (truth[0], truth[1] - 2.4, truth[2])
    cfg = ObjectSightingConfig(gate_m=3.0, max_correction_m=2.0)
    assert sight_object([_post(*_seen_from(truth, MAILBOX))], MAILBOX, far_off, stamp=0.0, cfg=cfg) is None
    belief = (truth[0], truth[1] - 1.0, truth[2])
    corr = ObjectCorrection()
    assert corr.correction == (0.0, 0.0)  # nothing seen: the belief as it is
    for k in range(4):
        corr.add(sight_object([_post(*_seen_from(truth, MAILBOX))], MAILBOX, belief, stamp=float(k)))
    corr.add(None)  # a frame without it changes nothing
    bad = _seen_from(truth, (MAILBOX[0], MAILBOX[1] + 1.5))
    corr.add(sight_object([_post(*bad)], MAILBOX, belief, stamp=5.0))
    assert corr.seen == 5 and math.dist(corr.correction, (0.0, 1.0)) < 1e-6


def test_the_amv_stops_in_its_lane_beside_the_mailbox_the_map_has() -> None:
    from eddie.messages.map_manager import StopAtObject, open_trigger_data
    from eddie.missions import compile_mission_files
    from eddie.missions.lane import shift_into_lane

    amv = compile_mission_files("worlds/amv-delivery.yaml", "worlds/north_hills.map.geojson")
    (stop,) = [open_trigger_data(a.data) for a in amv.annotations if a.type == "stop_at_object"]
    assert isinstance(stop, StopAtObject) and stop.object_id == "mailbox_dest"
    assert stop.object_xy == pytest.approx(MAILBOX, abs=0.01)  # the map's mailbox (1.5 m off the world's: a wrong map)
    goal = (-240.5868, 128.491)  # the map's place "mailbox", on Birch's centre line; the AMV drives south there
    assert stop.x < goal[0] - 1.0 and stop.y == pytest.approx(goal[1], abs=0.3)  # keep right: west of the centre
    # the route's lane: a quarter of the width to the right of travel, at every vertex
    north = np.array([[0.0, 0.0], [0.0, 10.0], [0.0, 20.0]])
    assert shift_into_lane(north, -1.5)[:, 0] == pytest.approx([1.5, 1.5, 1.5])
    bend = shift_into_lane(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]), 1.0)  # east, then north; 1 m left
    assert bend[0] == pytest.approx([0.0, 1.0]) and bend[2] == pytest.approx([9.0, 10.0])


def test_the_stop_at_an_object_comes_as_the_goal_is_reached_across_the_lane() -> None:
    from eddie.obstacle_stop.obstacle_stop_module import stop_now

    south = -math.pi / 2
    # 2 m/s, 0.3 s from the pose to the brakes: 0.6 m ahead
    assert not stop_now(0.0, -1.0, south, 2.0, reach=1.2)
    assert stop_now(0.0, -0.5, south, 2.0, reach=1.2)
    assert not stop_now(1.5, -0.5, south, 2.0, reach=1.2)  # 1.5 m across: not this lane's goal
    assert stop_now(0.5, 0.4, south, 0.0, reach=1.2)  # standing just past it
    assert not stop_now(0.0, -0.5, south, 0.0, reach=1.2)  # standing 0.5 m short: drive on


def test_the_stop_and_the_step_goal_are_beside_the_object_when_the_map_moved_it_from_its_place(tmp_path) -> None:
    # a map like one `sidewalk mapbuild` writes: the objects where the mapping run saw them, the places of the older
    # map; here the mailbox stands 3.1 m north of the place "mailbox" (seed 0's built map put it 3.06 m north)
    import json

    from eddie.messages.map_manager import StopAtObject, open_trigger_data
    from eddie.missions import compile_mission_files
    from eddie.missions.destination import destination_object, destination_point
    from eddie.mission_service.mission_progress import step_goals
    from modules.captain.missionfile import load_mission
    from modules.map_navigator.mapdata import load_map

    doc = json.loads(open("worlds/north_hills.map.geojson").read())
    (box,) = [f for f in doc["features"] if f["properties"].get("id") == "mailbox_dest"]
    x, y = box["geometry"]["coordinates"]
    box["geometry"]["coordinates"] = [x, y + 3.1]
    moved = tmp_path / "built.map.geojson"
    moved.write_text(json.dumps(doc))
    place = (-240.5868, 128.491)

    amv = compile_mission_files("worlds/amv-delivery.yaml", moved)
    (stop,) = [open_trigger_data(a.data) for a in amv.annotations if a.type == "stop_at_object"]
    assert isinstance(stop, StopAtObject) and stop.object_id == "mailbox_dest"
    assert stop.y == pytest.approx(y + 3.1, abs=0.3), "the stop is not beside the object the laser will see"
    assert stop.x < place[0] - 1.0  # still in the kept lane, west of Birch's centre
    m = load_map(moved)
    (g,) = step_goals(m, (0.3, -40.25), load_mission("worlds/amv-delivery.yaml"), vehicle="navlab")
    assert g.goal[1] == pytest.approx(y + 3.1, abs=0.3) and g.lane_goal is not None
    assert math.dist(g.lane_goal, (stop.x, stop.y)) < 0.05  # the mission service judges arrival where the stop is
    # on the shipped map the place and its mailbox agree: the point is the place, within centimetres along the road
    shipped = load_map("worlds/north_hills.map.geojson")
    _oid, oxy = destination_object(shipped, "mailbox", place)
    p = destination_point(place, oxy, [(-240.0, 240.0), (-240.5, 128.491)])
    assert abs(p[1] - place[1]) < 0.15
