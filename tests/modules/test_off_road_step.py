"""An off-road step: the MAP NAVIGATOR looks up no road and hands the PILOT one cross-country segment to the goal itself;
the PILOT drives it with the cross-country planner, its other segments with its road planner."""

from __future__ import annotations

import math

import numpy as np

import pytest

from codger.pilot.cross_country import CrossCountryOptions, frontier_goals, plans_on_terrain
from modules.map_navigator import NavigatorOptions, Planned, StepJob, load_map
from modules.map_navigator.describe import ARRIVAL_RADIUS_M
from modules.vocabulary import Destination, MissionStep, SegmentResult, StepConstraints, StepResult

pytestmark = pytest.mark.timeout(60)  # 1–6 s at load 5–7 (the cross-country map read once; not measured quiet)

GOAL = (395.142, 46.981)  # worlds/cross-country.yaml


@pytest.fixture(scope="module")
def cross_country():
    return load_map("cross_country")


def _step(dest: Destination, **cons) -> MissionStep:
    return MissionStep(mission_id="m", step_index=0, name="to the goal", destination=dest, constraints=StepConstraints(**cons))


def test_an_off_road_step_is_one_cross_country_segment_from_where_the_vehicle_is_to_the_goal_itself(cross_country) -> None:
    assert not cross_country.world.edges  # no road the navigator could route over
    job = StepJob(cross_country, _step(Destination(xy=GOAL, off_road=True)), (25.0, 33.019), NavigatorOptions(vehicle="navlab"))
    out = job.plan()
    assert isinstance(out, Planned) and len(out.segments) == 1
    seg = out.segments[0]
    assert seg.mode == "cross-country" and plans_on_terrain(seg)
    assert seg.centreline == ((25.0, 33.019), GOAL)
    assert seg.exit.point == GOAL and seg.exit.radius_m == ARRIVAL_RADIUS_M  # the arrival rule of every step
    assert seg.constraints.stop_at_exit and seg.constraints.speed_limit is not None
    assert seg.length_m == pytest.approx(math.hypot(GOAL[0] - 25.0, GOAL[1] - 33.019))
    assert out.plan.edge_ids == () and out.plan.goal_xy == GOAL
    assert job.current() == seg


def test_a_step_limit_below_the_cross_country_speed_is_kept(cross_country) -> None:
    out = StepJob(cross_country, _step(Destination(xy=GOAL, off_road=True), speed_limit=0.7), (25.0, 33.0)).plan()
    assert isinstance(out, Planned) and out.segments[0].constraints.speed_limit == 0.7


def test_a_failed_cross_country_segment_is_planned_again_from_where_it_stopped_until_the_replans_run_out(cross_country) -> None:
    job = StepJob(cross_country, _step(Destination(xy=GOAL, off_road=True)), (25.0, 33.0), NavigatorOptions(max_replans=1))
    seg = job.plan().segments[0]
    again = job.segment_done(SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=0, success=False,
                                           reason="stuck", end_xy=(120.0, 40.0), distance_m=95.0))
    assert isinstance(again, Planned) and again.segments[0].centreline[0] == (120.0, 40.0)
    assert again.segments[0].segment_id != seg.segment_id
    last = job.segment_done(SegmentResult(segment_id=again.segments[0].segment_id, plan_id=again.plan.plan_id, segment_index=0,
                                          success=False, reason="stuck"))
    assert isinstance(last, StepResult) and not last.success and "no replans left" in last.reason


def test_a_reached_cross_country_segment_ends_the_step(cross_country) -> None:
    job = StepJob(cross_country, _step(Destination(xy=GOAL, off_road=True)), (25.0, 33.0))
    seg = job.plan().segments[0]
    res = job.segment_done(SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=0, success=True,
                                         end_xy=(394.6, 47.3), distance_m=380.0))
    assert isinstance(res, StepResult) and res.success and res.segments_done == 1


def test_the_pilot_keeps_its_road_planner_for_a_road_segment() -> None:
    campus = load_map("campus")
    out = StepJob(campus, _step(Destination(place="library")), (0.3, -28.25)).plan()
    assert isinstance(out, Planned) and out.segments
    assert not any(plans_on_terrain(s) for s in out.segments)


def test_frontier_goals_lie_at_the_reach_toward_the_goal_nearest_first_and_never_past_it() -> None:
    opts = CrossCountryOptions()
    pts = frontier_goals(0.0, 0.0, (100.0, 0.0), opts)
    assert len(pts) == len(opts.frontier_reach_m) * len(opts.frontier_bearings)
    assert pts[0] == pytest.approx((max(opts.frontier_reach_m), 0.0))
    left = [math.hypot(100.0 - x, y) for x, y in pts]
    assert left == sorted(left)
    assert all(min(opts.frontier_reach_m) - 1e-9 <= math.hypot(x, y) <= max(opts.frontier_reach_m) + 1e-9 for x, y in pts)
    near = frontier_goals(0.0, 0.0, (8.0, 0.0), opts)  # the goal 8 m off: only points closer than it
    assert near and all(math.hypot(x, y) < 8.0 for x, y in near)


def test_a_plan_that_backs_up_reaches_the_helm_with_the_road_planners_directions() -> None:
    import numpy as np

    from codger.pilot.cross_country import planned_path
    from modules.terrain.cross_country_planner import CrossCountryPlan

    poses = np.array([[0.0, 0, 0], [0.2, 0, 0], [0.4, 0, 0], [0.2, 0, 0], [0.0, 0, 0]])
    plan = CrossCountryPlan(poses, np.zeros(5), np.zeros(5, np.int8), 0.8, 1, 1, (), 1, 1, 1, 0.1,
                            direction=np.array([1.0, 1.0, 1.0, -1.0, -1.0]))
    from modules.terrain.vehicle_model import TERREGATOR_TERRAIN, NAVLAB_TERRAIN

    path = planned_path(plan, TERREGATOR_TERRAIN)
    assert path.direction.tolist() == [1.0, 1.0, -1.0, -1.0, -1.0]  # the motion leaving each pose
    assert path.s.tolist() == pytest.approx([0.0, 0.2, 0.4, 0.6, 0.8])
    navlab = planned_path(plan, NAVLAB_TERRAIN)  # its pose frame is its rear axle, 1.85 m behind the planner's point
    assert navlab.poses[:, 0].tolist() == pytest.approx([-1.85, -1.65, -1.45, -1.65, -1.85])


def test_backing_up_retraces_the_vehicles_own_track_in_reverse() -> None:
    from codger.pilot.cross_country import retreat_path

    trail = [(float(x), 0.5 * float(x), 0.46) for x in np.arange(0.0, 10.01, 0.25)]  # oldest first
    back = retreat_path(trail, 4.0)
    assert back is not None and (back.direction == -1.0).all()
    assert tuple(back.poses[0]) == trail[-1]  # from where the vehicle stands
    assert 4.0 <= back.length < 4.0 + 0.3
    assert all(tuple(p) in trail for p in back.poses)  # only where it has been
    assert retreat_path(trail[:4], 4.0) is None  # too little track to back up on


def test_a_manoeuvre_goes_to_the_helm_one_leg_at_a_time() -> None:
    from codger.pilot.cross_country import first_leg
    from modules.pilot.planner import PlannedPath

    poses = np.array([[0.0, 0, 0], [0.2, 0, 0], [0.4, 0, 0], [0.2, 0, 0], [0.0, 0, 0], [0.2, 0.1, 0.3]])
    path = PlannedPath(poses=poses, s=np.arange(6) * 0.2, direction=np.array([1.0, 1, -1, -1, 1, 1]), curvature=np.zeros(6))
    leg = first_leg(path)
    assert leg.poses.tolist() == poses[:3].tolist() and (leg.direction == 1.0).all()  # up to the cusp, forward
    whole = PlannedPath(poses=poses[:3], s=np.arange(3) * 0.2, direction=np.ones(3), curvature=np.zeros(3))
    assert first_leg(whole) is whole
