"""MAP NAVIGATOR pure core: route selection under constraints, segmentation by mode, descriptions, replans."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from modules.map_navigator import (
    TURN_SPEED_M_S, vehicle_describe_radius,
    MapData, NavigatorOptions, NoRouteError, Planned, RouteOptions, SegmentOptions, StepJob, UnknownPlaceError,
    describe_segment, exit_condition, fillet_corner, fillet_radius, heading_change, lateral_offset, load_map, segment_route, select_route,
)
from codger.map_navigator.__main__ import start_position
from modules.vocabulary import Destination, MissionStep, SegmentResult, StepConstraints, StepResult

DORM = (0.3, -28.25)


@pytest.fixture(scope="module")
def campus() -> MapData:
    return load_map("campus")


@pytest.fixture(scope="module")
def hills() -> MapData:
    return load_map("north_hills")


def _route(m: MapData, dest: str, start=DORM, **cons):
    vehicle = cons.pop("vehicle", "terregator")
    return select_route(m, start, Destination(place=dest), StepConstraints(**cons), RouteOptions(vehicle=vehicle))


# ---- route selection -----------------------------------------------------------------------


def test_shortest_route_to_the_library_takes_the_stairs(campus: MapData) -> None:
    r = _route(campus, "library")
    assert "e_stairs" in r.edge_ids and "e_slope" not in r.edge_ids
    assert r.node_ids[0] == "dorm" and r.node_ids[-1] == "library"
    assert r.goal_name == "library"


@pytest.mark.parametrize("cons", [{"avoid_stairs": True}, {"vehicle": "navlab"}])
def test_avoid_stairs_and_the_navlab_take_the_slope(campus: MapData, cons: dict) -> None:
    shortest = _route(campus, "library")
    r = _route(campus, "library", **cons)
    assert "e_slope" in r.edge_ids and "e_stairs" not in r.edge_ids
    assert r.cost > shortest.cost


def test_avoid_both_leaves_no_route_and_says_why(campus: MapData) -> None:
    with pytest.raises(NoRouteError, match=r"e_stairs: stairs \(avoid_stairs\).*e_slope: slope \(avoid_slope\)"):
        _route(campus, "library", avoid_stairs=True, avoid_slope=True)


def test_unknown_place_lists_the_known_ones(campus: MapData) -> None:
    with pytest.raises(UnknownPlaceError, match="unknown place 'atlantis'.*library"):
        _route(campus, "atlantis")


def test_cost_multipliers_weigh_the_route(campus: MapData) -> None:
    r = _route(campus, "library")
    assert r.cost > r.length  # stairs cost 1.5 per metre
    flat = _route(campus, "quad")
    assert flat.cost == pytest.approx(flat.length, rel=1e-6)


def test_coordinates_are_projected_onto_the_nearest_path(campus: MapData) -> None:
    r = select_route(campus, (30.0, 0.5), Destination(xy=(40.0, 0.6)), StepConstraints())
    assert r.edge_ids == ("e_s1",) and r.node_ids == ()
    assert r.length == pytest.approx(10.0, abs=0.05)
    back = select_route(campus, (40.0, 0.6), Destination(xy=(30.0, 0.5)), StepConstraints())
    assert back.legs[0].coords[0][0] > back.legs[0].coords[-1][0]  # driven westwards


def test_blocked_edges_are_routed_around(campus: MapData) -> None:
    r = select_route(campus, DORM, Destination(place="quad"), StepConstraints(),
                     RouteOptions(blocked_edges=frozenset({"e_s2"})))
    assert "e_s2" not in r.edge_ids and r.node_ids[-1] == "quad"


def test_routes_are_deterministic(campus: MapData) -> None:
    assert _route(campus, "chapel") == _route(campus, "chapel")


# ---- segmentation ----------------------------------------------------------------------------


def test_segments_have_one_mode_each_and_cover_the_route(campus: MapData) -> None:
    r = _route(campus, "library", avoid_stairs=True)
    segs = segment_route(r, campus)
    modes = [s.mode for s in segs]
    assert modes == ["follow-road", "turn-at-intersection", "follow-road", "turn-at-intersection", "follow-road",
                     "turn-at-intersection", "follow-road", "go-through-slope", "follow-road",
                     "go-through-intersection", "follow-road"]
    for a, b in zip(segs, segs[1:]):
        assert math.dist(a.coords[-1], b.coords[0]) < 1e-6  # contiguous
    assert sum(s.length for s in segs) == pytest.approx(r.length, abs=0.5)
    slope = next(s for s in segs if s.mode == "go-through-slope")
    assert slope.path_objects == ("slope_ramp", "sw_plaza")
    inter = [s for s in segs if "intersection" in s.mode]
    assert [s.path_objects for s in inter] == [("x_dorm_walk",), ("x_hall",), ("x_stairs",), ("x_terrace",)]


def test_turns_are_told_from_going_through(hills: MapData) -> None:
    r = select_route(hills, (0.3, -40.25), Destination(place="mailbox"), StepConstraints(), RouteOptions(vehicle="navlab"))
    segs = segment_route(r, hills, SegmentOptions(turn_radius_m=7.0))
    inter = [(s.node_id, s.mode) for s in segs if "intersection" in s.mode]
    assert inter == [("x_oak_maple", "go-through-intersection"), ("x_oak_elm", "turn-at-intersection"),
                     ("x_elm_pine", "go-through-intersection"), ("x_elm_birch", "turn-at-intersection")]
    for s in segs:
        if s.mode == "turn-at-intersection":
            assert heading_change(s.coords[:2], s.coords[-2:]) > math.radians(60)  # left turns
            assert s.length >= 2 * 7.0  # room for the Navlab's 7 m turning radius on both sides


def _min_radius(coords, spacing: float = 1.0) -> float:
    """Return the smallest radius [m] of the circles through points `spacing` [m] apart along a polyline."""
    line = shapely.LineString(coords)
    xy = np.array([(p.x, p.y) for p in (line.interpolate(v) for v in np.arange(0.0, line.length, 0.1))])
    k = int(round(spacing / 0.1))
    a, b, c = xy[: -2 * k], xy[k:-k], xy[2 * k:]
    cross = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    r = np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1) * np.linalg.norm(a - c, axis=1) / np.maximum(2 * cross, 1e-12)
    return float(r.min())


def test_navlab_turns_round_the_corner_with_its_turning_radius(hills: MapData) -> None:
    r = select_route(hills, (0.3, -40.25), Destination(place="mailbox"), StepConstraints(), RouteOptions(vehicle="navlab"))
    segs = segment_route(r, hills, SegmentOptions(turn_radius_m=7.0))
    turns = [s for s in segs if s.mode == "turn-at-intersection"]
    assert len(turns) == 2
    for s in turns:
        assert fillet_radius(7.0, s.width) == pytest.approx(7.0 + s.width / 4)
        # the arc stays drivable for a 7 m radius even offset inwards by the keep-right/left offset (width/4)
        assert _min_radius(s.coords) - s.width / 4 >= 7.0 * 0.97
        # and the arc lies on the intersection's roads: every vertex within the path objects ∪ the roads
        roads = shapely.union_all([o.footprint for o in hills.world.objects if o.kind in ("road", "intersection")])
        assert all(roads.buffer(0.05).covers(shapely.Point(p)) for p in s.coords)


def test_terregator_turns_keep_the_corner(campus: MapData) -> None:
    r = _route(campus, "quad")
    segs = segment_route(r, campus, SegmentOptions(turn_radius_m=0.0))
    turn = next(s for s in segs if s.mode == "turn-at-intersection")
    k = next(i for i, p in enumerate(turn.coords) if math.dist(p, (campus.world.node(turn.node_id).x, campus.world.node(turn.node_id).y)) < 1e-6)
    assert 0 < k < len(turn.coords) - 1  # the node itself is a vertex: a sharp corner, turned in place


def test_fillet_corner_is_tangent_to_both_legs() -> None:
    coords = ((0.0, -12.0), (0.0, 0.0), (-12.0, 0.0))
    out = fillet_corner(coords, 12.0, 8.5)
    assert out[0] == (0.0, -12.0) and out[-1] == (-12.0, 0.0)
    assert (0.0, -8.5) in out and any(math.dist(p, (-8.5, 0.0)) < 1e-6 for p in out)
    assert _min_radius(out) == pytest.approx(8.5, rel=0.03)
    assert fillet_corner(coords, 12.0, 0.0) == coords and fillet_corner(coords, 12.0, 13.0) == coords


def test_turn_radius_widens_intersection_segments(campus: MapData) -> None:
    r = _route(campus, "quad")
    tight = [s.length for s in segment_route(r, campus, SegmentOptions(turn_radius_m=0.0)) if "intersection" in s.mode]
    wide = [s.length for s in segment_route(r, campus, SegmentOptions(turn_radius_m=7.0)) if "intersection" in s.mode]
    assert all(w > t for w, t in zip(wide, tight))


# ---- description -----------------------------------------------------------------------------


def test_segment_description_copies_objects_from_the_map(campus: MapData) -> None:
    r = _route(campus, "library", avoid_stairs=True)
    segs = segment_route(r, campus)
    i = next(k for k, s in enumerate(segs) if s.mode == "go-through-slope")
    d = describe_segment(segs[i], campus, segment_id="p.7", plan_id="p", index=i,
                         constraints=StepConstraints(keep="right", speed_limit=0.8), last=False)
    assert d.mode == "go-through-slope" and d.path_object_ids == ("slope_ramp", "sw_plaza")
    ids = [o.object_id for o in d.objects]
    assert ids[:2] == ["slope_ramp", "sw_plaza"]
    assert "stairs_main" in ids  # the grey stairs beside the slope: what perception must tell apart
    slope = d.objects[0]
    assert slope.shape.type == "slope" and slope.cost == pytest.approx(1.2) and slope.colour is not None
    assert d.constraints.keep == "right" and d.constraints.lateral_offset_m == pytest.approx(-d.width_m / 4)
    assert d.constraints.speed_limit == 0.8 and not d.constraints.stop_at_exit
    assert d.exit.point == d.centreline[-1]


def test_exit_gate_is_across_the_path_at_the_end() -> None:
    ex = exit_condition(((0.0, 0.0), (10.0, 0.0)), width=3.0)
    assert ex.point == (10.0, 0.0) and ex.heading == pytest.approx(0.0)
    (ax, ay), (bx, by) = ex.gate
    assert ax == pytest.approx(10.0) and bx == pytest.approx(10.0) and abs(ay - by) == pytest.approx(4.0)
    assert lateral_offset("right", 4.0) == -1.0 and lateral_offset("left", 4.0) == 1.0 and lateral_offset(None, 4.0) == 0.0


# ---- a step: one segment at a time, replanning ---------------------------------------------


def _step(dest: str, **cons) -> MissionStep:
    return MissionStep(mission_id="m", step_index=0, name="s", destination=Destination(place=dest), constraints=StepConstraints(**cons))


def _ok(seg, end=None) -> SegmentResult:
    return SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=seg.segment_index, success=True, end_xy=end)


def test_step_hands_out_segments_one_at_a_time_then_succeeds(campus: MapData) -> None:
    job = StepJob(campus, _step("quad", keep="right"), DORM)
    planned = job.plan()
    assert isinstance(planned, Planned)
    assert planned.plan.plan_id == "m.0.0" and planned.plan.segment_count == len(planned.segments)
    assert [s.constraints.stop_at_exit for s in planned.segments][-1] is True
    assert not any(s.constraints.stop_at_exit for s in planned.segments[:-1])
    seen = []
    out = job.current()
    while not isinstance(out, StepResult):
        seen.append(out.segment_id)
        assert job.current() is out
        out = job.segment_done(_ok(out))
    assert out.success and out.segments_done == len(seen) == len(planned.segments)
    assert out.route_length_m == pytest.approx(planned.plan.length_m, abs=0.5)
    assert job.position == planned.segments[-1].exit.point


def test_failed_segment_replans_around_it(campus: MapData) -> None:
    job = StepJob(campus, _step("quad"), DORM)
    first = job.plan()
    seg = job.current()
    seg = job.segment_done(_ok(seg))  # the turn at the dorm walk
    seg = job.segment_done(_ok(seg))  # now on the south walk e_s1
    assert "sw_s1" in seg.path_object_ids
    out = job.segment_done(SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=seg.segment_index,
                                         success=False, reason="blocked by a bench", end_xy=(20.0, 0.0)))
    assert isinstance(out, Planned) and out.plan.revision == 1 and out.plan.plan_id == "m.0.1"
    assert "e_s1" not in out.plan.edge_ids[1:] and out.plan.node_ids[-1] == "quad"  # only to drive back off it
    assert out.plan.plan_id != first.plan.plan_id


def test_replan_from_mid_edge_drives_back_the_way_it_came(campus: MapData) -> None:
    job = StepJob(campus, _step("quad"), DORM)
    job.plan()
    seg = job.segment_done(_ok(job.current()))
    seg = job.segment_done(_ok(seg))
    assert seg.mode == "follow-road" and "sw_s1" in seg.path_object_ids  # eastwards on the south walk
    out = job.segment_done(SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=seg.segment_index,
                                         success=False, reason="blocked", end_xy=(20.0, 0.0)))
    assert isinstance(out, Planned)
    first = out.segments[0]
    assert math.dist(first.centreline[0], (20.0, 0.0)) < 0.5  # starts where the vehicle is …
    assert first.centreline[-1][0] < first.centreline[0][0]  # … and drives back west
    assert out.plan.edge_ids[0] == "e_s1" and "e_west" in out.plan.edge_ids


def test_a_start_far_from_every_path_has_no_route(campus: MapData) -> None:
    with pytest.raises(NoRouteError, match="no usable path within 10 m of the start"):
        select_route(campus, (30.0, 30.0), Destination(place="quad"), StepConstraints())


def test_replans_are_limited_and_the_reason_is_kept(campus: MapData) -> None:
    job = StepJob(campus, _step("quad"), DORM, NavigatorOptions(max_replans=0))
    job.plan()
    seg = job.current()
    out = job.segment_done(SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=0, success=False, reason="lost"))
    assert isinstance(out, StepResult) and not out.success
    assert "segment 0 (follow-road) failed: lost" in out.reason and "no replans left" in out.reason


def test_unknown_place_and_unreachable_fail_the_step_with_a_reason(campus: MapData) -> None:
    out = StepJob(campus, _step("atlantis"), DORM).plan()
    assert isinstance(out, StepResult) and not out.success and "unknown place 'atlantis'" in out.reason
    out = StepJob(campus, _step("library", avoid_stairs=True, avoid_slope=True), DORM).plan()
    assert isinstance(out, StepResult) and not out.success and "no route" in out.reason


def test_already_there_succeeds_at_once(campus: MapData) -> None:
    job = StepJob(campus, _step("dorm"), DORM)
    out = job.plan()
    assert isinstance(out, Planned) and out.segments == ()
    assert job.result is not None and job.result.success and job.current() is None


def test_start_position_parsing(campus: MapData) -> None:
    assert start_position(campus, None) == (campus.world.start.x, campus.world.start.y)
    assert start_position(campus, "1.5,-2") == (1.5, -2.0)
    node = campus.find_place("quad")
    assert start_position(campus, "quad") == (node.x, node.y)
    with pytest.raises(ValueError, match="neither"):
        start_position(campus, "nowhere")


def test_a_goal_point_on_the_failed_edge_is_reached_from_its_far_end(campus: MapData) -> None:
    st = MissionStep(mission_id="m", step_index=0, name="s", destination=Destination(xy=(60.0, 30.0)))
    job = StepJob(campus, st, DORM)
    job.plan()
    seg = job.current()
    while "sw_hall_ns" not in seg.path_object_ids:
        seg = job.segment_done(_ok(seg))
    out = job.segment_done(SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=seg.segment_index,
                                         success=False, reason="stuck", end_xy=seg.centreline[0]))
    assert isinstance(out, Planned), out
    assert out.plan.edge_ids[-1] == "e_hall_ns" and out.plan.edge_ids.count("e_hall_ns") == 2  # back off, come round
    assert "i_stairs" in out.plan.node_ids and out.plan.goal_xy == pytest.approx((59.98, 30.0), abs=0.3)
    last = out.segments[-1]
    assert last.centreline[-1][1] < last.centreline[0][1]  # arrives from the north


def test_a_spur_joining_a_walk_mid_way_is_entered_without_driving_past_it(campus: MapData) -> None:
    # The hall's spur edge runs along the south walk to the next intersection: the route must not
    # drive on to that intersection and come back (dorm → hall over the walks is about 66 m).
    r = _route(campus, "hall", keep="right")
    assert r.length == pytest.approx(66.0, abs=1.5)
    assert "i_hall" not in r.node_ids
    xs = [x for leg in r.legs for x, _ in leg.coords]
    assert max(xs) < 31.0
    plans = segment_route(r, campus)
    assert [p.mode for p in plans][-1] == "follow-road"
    assert math.dist(plans[-1].coords[-1], (30.1111, 7.9066)) < 0.5


def _fail(seg, reason="stuck", end=None) -> SegmentResult:
    return SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=seg.segment_index, success=False,
                         reason=reason, end_xy=end)


def test_with_no_way_around_a_failed_segment_the_same_way_is_tried_again(hills: MapData) -> None:
    job = StepJob(hills, _step("mailbox", keep="right"), (0.3, -40.25), NavigatorOptions(vehicle="navlab", max_replans=2))
    job.plan()
    seg = job.current()
    while "road_elm_1" not in seg.path_object_ids:
        seg = job.segment_done(_ok(seg))
    where = seg.centreline[len(seg.centreline) // 3]
    out = job.segment_done(_fail(seg, end=where))  # Elm Ave is the only way to the mailbox
    assert isinstance(out, Planned) and job.retried and out.plan.revision == 1
    assert out.plan.edge_ids[0] == "e_elm_1" and math.dist(out.segments[0].centreline[0], where) < 0.5
    res = _fail(job.current(), end=where).model_copy(update={"distance_m": 5.0})  # the retry got somewhere: again
    out = job.segment_done(res)
    assert isinstance(out, Planned) and out.plan.revision == 2
    out = job.segment_done(_fail(job.current(), end=where))
    assert isinstance(out, StepResult) and not out.success and "no replans left (2 allowed)" in out.reason


def test_a_retry_that_got_nowhere_is_not_retried(hills: MapData) -> None:
    job = StepJob(hills, _step("mailbox", keep="right"), (0.3, -40.25), NavigatorOptions(vehicle="navlab", max_replans=5))
    job.plan()
    seg = job.current()  # Oak St: the only way north
    out = job.segment_done(_fail(seg, end=seg.centreline[1]))
    assert isinstance(out, Planned) and job.retried
    out = job.segment_done(_fail(job.current(), reason="no progress", end=seg.centreline[1]))  # no distance_m: stuck
    assert isinstance(out, StepResult) and not out.success
    assert "failed: no progress" in out.reason and "replanning failed: no route" in out.reason and "failed before" in out.reason


def test_navlab_descriptions_reach_farther_and_slow_the_turns(hills: MapData) -> None:
    step = _step("mailbox", keep="right", speed_limit=5.0)
    nav = StepJob(hills, step, (0.3, -40.25), NavigatorOptions(vehicle="navlab")).plan()
    ter = StepJob(hills, step, (0.3, -40.25), NavigatorOptions(vehicle="terregator")).plan()
    assert vehicle_describe_radius("navlab", 8.0) >= 12.0 and vehicle_describe_radius("terregator", 8.0) == 8.0
    for seg in nav.segments:
        if seg.mode == "turn-at-intersection":  # slowly, along the turn's arc
            assert seg.constraints.speed_limit == TURN_SPEED_M_S
            assert seg.constraints.keep is None and seg.constraints.lateral_offset_m == 0.0
        else:
            assert seg.constraints.speed_limit == 5.0
            assert seg.constraints.keep == "right" and seg.constraints.lateral_offset_m == pytest.approx(-seg.width_m / 4)
    # objects between 8 and 12 m of a Navlab segment are described (a Dubins arc may swing that far)
    def ids(planned):
        return {o.object_id for s in planned.segments for o in s.objects}
    extra = ids(nav) - ids(ter)
    assert any(i.startswith(("tree_", "mailbox_")) for i in extra)
    assert all(s.constraints.speed_limit == 5.0 and s.constraints.keep == "right" for s in ter.segments)
