"""Missions compile into trigger annotations along the MAP NAVIGATOR's route (issue 9 item 6)."""

from __future__ import annotations

import pytest
import shapely

from eddie.annotated_map import AnnotationDatabase, TriggerWalker
from eddie.messages.map_manager import DeadReckonThrough, RouteSegment, SetSpeed, StopAtObject, open_trigger_data
from eddie.missions import MissionCompileError, compile_mission_files


@pytest.fixture(scope="module")
def amv():
    return compile_mission_files("worlds/amv-delivery.yaml", "worlds/north_hills.map.geojson")


def test_amv_delivery_speeds_and_dead_reckoning(amv) -> None:
    segs = [open_trigger_data(a.data) for a in amv.annotations if a.type == "route"]
    assert all(isinstance(s, RouteSegment) for s in segs)
    inter = [s for s in segs if "intersection" in s.mode]
    straight = [s for s in segs if "intersection" not in s.mode]
    assert len(inter) == 4 and straight
    assert {s.speed for s in inter} == {0.5} and {s.speed for s in straight} == {3.0}
    dr = [open_trigger_data(a.data) for a in amv.annotations if a.type == "dead_reckon_intersection"]
    assert sorted(d.node_id for d in dr) == sorted(s.node_id for s in inter)
    for d, s in zip(sorted(dr, key=lambda d: d.node_id), sorted(inter, key=lambda s: s.node_id)):
        assert isinstance(d, DeadReckonThrough) and d.points == s.points and d.speed == 0.5
    stop = [open_trigger_data(a.data) for a in amv.annotations if a.type == "stop_at_object"]
    assert len(stop) == 1 and isinstance(stop[0], StopAtObject) and stop[0].action == "stop"
    assert "mailbox" in stop[0].object_id


def test_driving_the_route_fires_the_profile_in_order(amv) -> None:
    db = AnnotationDatabase(amv.annotations)
    line = [p for a in amv.annotations if a.type == "route" for p in a.location.points]
    w = TriggerWalker(db)
    fired = []
    for x, y in line:
        fired += [e.annotation for e in w.advance(x, y) if e.kind == "fired"]
    triggers = [a for a in amv.annotations if a.trigger == "cross"]
    assert sorted(a.id for a in fired) == sorted(a.id for a in triggers)  # each exactly once
    speeds = [open_trigger_data(a.data).speed for a in fired if a.type == "set_speed"]
    assert speeds == [3.0] + [0.5, 3.0] * 4
    order = [a.id for a in fired]
    for a in fired:  # per intersection: slow down, dead-reckon, then resume vision
        if a.type == "dead_reckon_intersection":
            node = a.id.rsplit(".", 1)[0]
            assert order.index(f"{node}.slow") < order.index(a.id) < order.index(f"{node}.resume_vision")
    assert fired[-1].type == "stop_at_object"
    # fast obstacle detection: switched on at the start, off through each intersection and on again after it
    switches = [a.type for a in fired if a.type in ("start_obstacles", "stop_obstacles")]
    assert switches[0] == "start_obstacles" and switches == ["start_obstacles"] + ["stop_obstacles", "start_obstacles"] * 4


def test_campus_tour_steps_and_limits() -> None:
    c = compile_mission_files("worlds/campus-tour.yaml", "worlds/campus.map.geojson")
    stops = [open_trigger_data(a.data) for a in c.annotations if a.type == "stop_at_object"]
    assert [s.action for s in stops] == ["continue", "continue", "wait", "stop"]
    slope = [open_trigger_data(a.data) for a in c.annotations if a.id.startswith("s3.") and a.type == "set_speed"]
    assert slope and all(isinstance(s, SetSpeed) and s.speed <= 0.8 for s in slope)


def test_every_steps_stop_fires_on_a_drive_in_the_kept_lane_round_every_corner() -> None:
    """The campus tour's slope step (slope_bottom → stairs_top, 15 m) is shorter than the stop's 20 m lead: its
    gate lay at the route's start, on the corner from the quad's walk, which a vehicle keeping right turns inside
    of without crossing: EDDIE never waited at the plaza (lock-step campus tours, sessions 28–29)."""
    c = compile_mission_files("worlds/campus-tour.yaml", "worlds/campus.map.geojson")
    points = [p for a in c.annotations if a.type == "route" for p in a.location.points]
    lane = shapely.LineString(points).offset_curve(-0.8)  # the right-hand lane, one continuous track round each corner
    n = int(lane.length / 0.25)
    w = TriggerWalker(AnnotationDatabase(c.annotations))
    fired = [e.annotation.id for i in range(n + 1) for e in w.advance(*lane.interpolate(i * lane.length / n).coords[0])
             if e.kind == "fired"]
    assert [f for f in fired if f.endswith(".stop")] == ["s1.stop", "s2.stop", "s3.stop", "s4.stop"]


def test_bad_inputs_name_the_file(tmp_path) -> None:
    with pytest.raises(MissionCompileError, match="nope.yaml"):
        compile_mission_files(tmp_path / "nope.yaml", "worlds/north_hills.map.geojson")
    bad = tmp_path / "m.yaml"
    bad.write_text("mission: x\nsteps:\n  - destination: nowhere_at_all\n")
    with pytest.raises(MissionCompileError, match="nowhere_at_all"):
        compile_mission_files(bad, "worlds/north_hills.map.geojson")


def test_vision_through_intersections_replaces_dead_reckoning() -> None:
    c = compile_mission_files("worlds/amv-delivery.yaml", "worlds/north_hills.map.geojson", intersections="vision")
    types = [a.type for a in c.annotations]
    assert types.count("vision_through_intersection") == 4
    assert "dead_reckon_intersection" not in types and "resume_vision" not in types


def test_fast_obstacle_detection_is_off_from_well_before_the_stairs_to_their_top(tmp_path) -> None:
    # a generated campus whose route climbs the stairs (issue 37): with detection on, EDDIE's obstacle stop held the
    # vehicle at their foot for "something 4.5 m ahead on the path" (the risers) until the mission failed
    from vehicle_sim.generated.campus import generate, write

    write(generate(0), tmp_path)
    cm = compile_mission_files(str(tmp_path / "campus_0.yaml"), str(tmp_path / "campus_0.map.geojson"))
    segs = [open_trigger_data(a.data) for a in cm.annotations if a.type == "route"]
    stairs = [s for s in segs if s.mode == "climb-stairs"]
    assert len(stairs) == 1
    db = AnnotationDatabase(cm.annotations)
    w = TriggerWalker(db)
    route = shapely.LineString([p for s in segs for p in s.points])
    foot, top = (route.project(shapely.Point(*stairs[0].points[i])) for i in (0, -1))
    on = False  # detection, as the walk fires its gates
    state_at: list[tuple[float, bool]] = []
    for d in [i * 0.25 for i in range(int(route.length / 0.25) + 1)]:
        p = route.interpolate(d)
        for e in w.advance(p.x, p.y):
            if e.kind == "fired" and e.annotation.type in ("start_obstacles", "stop_obstacles"):
                on = e.annotation.type == "start_obstacles"
        state_at.append((d, on))
    # off from obstacle stop's reach (15 m) before the foot to the top; on again after the top
    assert all(not on for d, on in state_at if foot - 15.0 <= d <= top - 0.5), "detection on where it sees the risers"
    assert any(on for d, on in state_at if d > top + 1.0)
    assert any(on for d, on in state_at if d < foot - 20.0)
