"""LOCAL PATH PLANNER: turning radius honoured, region with margin respected, reproducible, clear failures."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point

from modules.pilot.local_path_constraints import NavigatorConfig, local_constraints
from modules.pilot.planner import LocalPathPlanner, PlannerConfig, PlanningError
from modules.pilot.polyline import PathLine
from modules.pilot.speed_profile import SpeedConfig, speed_profile

MARGIN = 0.8
CORNER = LineString([(-5, 0), (20, 0), (20, 25), (45, 25)])


def _inside_with_margin(raw, poses, margin=MARGIN, tol=1e-6):
    boundary = raw.boundary
    for x, y, _ in poses:
        if not raw.contains(Point(x, y)) or boundary.distance(Point(x, y)) < margin - tol:
            return False
    return True


@pytest.mark.parametrize("kind", ["dubins", "reeds_shepp"])
def test_navlab_path_honours_turning_radius_and_region(kind):
    raw = CORNER.buffer(5.0, join_style="mitre")
    region = raw.buffer(-MARGIN)
    plan = LocalPathPlanner(PlannerConfig(kind=kind, turning_radius=7.0), seed=3).plan([0, 0, 0], [[40, 25, 0]], region)
    assert np.max(np.abs(plan.curvature)) <= 1 / 7.0 + 1e-4
    assert _inside_with_margin(raw, plan.poses)
    steps = np.hypot(*np.diff(plan.poses[:, :2], axis=0).T)
    assert np.all(steps <= 0.25 + 1e-6)
    assert np.allclose(plan.poses[0], [0, 0, 0], atol=1e-6)
    assert np.hypot(*(plan.poses[-1, :2] - [40, 25])) < 0.5


def test_straight_corridor_with_waypoints_uses_analytic_curves():
    path = PathLine.from_points([(0, 0), (30, 0)])
    raw = LineString(path.xy).buffer(2.0, cap_style="flat")
    cons = local_constraints(path, [raw], [30.0 - 0.1], [False], keep="right", cfg=NavigatorConfig(margin=MARGIN, keep_offset=0.5))
    assert cons.lateral_offset == pytest.approx(-0.5)
    plan = LocalPathPlanner(PlannerConfig(kind="dubins"), seed=3).plan([1, 0.3, 0], list(cons.goals), cons.region)
    assert _inside_with_margin(raw, plan.poses)
    assert plan.poses[-1, 1] == pytest.approx(-0.5, abs=1e-6)
    assert np.max(np.abs(plan.curvature)) <= 1 / 7.0 + 1e-4


def test_terregator_se2_turns_in_place_and_stays_inside():
    raw = CORNER.buffer(2.0, join_style="mitre")
    region = raw.buffer(-0.6)
    plan = LocalPathPlanner(PlannerConfig(kind="se2"), seed=3).plan([0, 0, 0], [[40, 25, 0]], region)
    assert _inside_with_margin(raw, plan.poses, margin=0.6)
    # Headings follow the straight pieces: between samples the position moves along the heading.
    d = np.diff(plan.poses[:, :2], axis=0)
    along = d[:, 0] * np.cos(plan.poses[1:, 2]) + d[:, 1] * np.sin(plan.poses[1:, 2])
    assert np.allclose(along, np.hypot(*d.T), atol=1e-6)


def test_goal_outside_region_and_impossible_turn_fail_clearly():
    raw = CORNER.buffer(1.5, join_style="mitre")
    region = raw.buffer(-MARGIN)
    pl = LocalPathPlanner(PlannerConfig(kind="dubins", max_iterations=2000), seed=3)
    with pytest.raises(PlanningError, match="outside the navigable region"):
        pl.plan([0, 0, 0], [[40, 40, 0]], region)
    # A 1.4 m wide corridor with a right-angle corner cannot be taken with a 7 m turning radius.
    with pytest.raises(PlanningError, match="no path"):
        pl.plan([0, 0, 0], [[40, 25, 0]], region)


def test_same_seed_same_path_across_processes():
    code = (
        "import json, numpy as np;"
        "from shapely.geometry import LineString;"
        "from modules.pilot.planner import LocalPathPlanner, PlannerConfig;"
        "r = LineString([(-5,0),(20,0),(20,25),(45,25)]).buffer(5.0, join_style='mitre').buffer(-0.8);"
        "p = LocalPathPlanner(PlannerConfig(kind='dubins'), seed=11).plan([0,0,0],[[40,25,0]], r);"
        "print(json.dumps(p.poses.round(9).tolist()))"
    )
    outs = [
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True).stdout
        for _ in range(2)
    ]
    a, b = (np.array(json.loads(o.splitlines()[0])) for o in outs)
    assert a.shape == b.shape and np.array_equal(a, b)


def test_speed_profile_limits_and_stops():
    s = np.arange(0, 20.01, 0.25)
    k = np.where((s > 8) & (s < 12), 1 / 7.0, 0.0)
    v = speed_profile(s, k, np.ones_like(s), 3.0, cfg=SpeedConfig(max_lateral_accel=1.0, max_decel=1.0))
    assert v[-1] == 0.0 and np.all(v <= 3.0 + 1e-12)
    assert np.all(v[(s > 8) & (s < 12)] <= math.sqrt(7.0) + 1e-9)
    dv2 = v[:-1] ** 2 - v[1:] ** 2
    assert np.all(dv2 <= 2 * 1.0 * np.diff(s) + 1e-9)  # never brakes harder than max_decel
    d = np.where(s < 10, 1.0, -1.0)
    v2 = speed_profile(s, np.zeros_like(s), d, 1.0)
    assert v2[np.argmax(s >= 10)] == 0.0 and np.all(v2[s > 10.5] <= 0.0)


def test_start_outside_the_region_finds_its_way_back_in():
    raw = LineString([(0, 0), (30, 0)]).buffer(2.0, cap_style="flat")
    region = raw.buffer(-0.5)
    plan = LocalPathPlanner(PlannerConfig(kind="se2", start_slack=1.0), seed=3).plan([5, 3.2, 0], [[25, 0, 0]], region)
    inside = [shapely.contains_xy(region, x, y) for x, y, _ in plan.poses]
    assert not inside[0] and all(inside[len(inside) // 2 :])


def test_footprint_points_keep_the_whole_body_inside():
    raw = CORNER.buffer(5.0, join_style="mitre")
    region = raw.buffer(-MARGIN)
    fx = (0.0, 1.5, 3.0)  # rear axle frame: the body reaches forward
    plan = LocalPathPlanner(PlannerConfig(kind="dubins", footprint_x=fx), seed=3).plan([0, 0, 0], [[36, 25, 0]], region)
    for x, y, yaw in plan.poses:
        pts = [(x + d * math.cos(yaw), y + d * math.sin(yaw)) for d in fx]
        assert all(shapely.contains_xy(region, px, py) for px, py in pts)
    # A goal inside the region whose front would stick out of it (the cap ends at x = 49.2) is refused.
    with pytest.raises(PlanningError, match="outside"):
        LocalPathPlanner(PlannerConfig(kind="dubins", footprint_x=fx), seed=3).plan([0, 0, 0], [[47.5, 25, 0]], region)


def test_forward_only_failure_falls_back_to_reversing():
    from shapely.geometry import box

    region = box(0, -5, 30, 5).buffer(-MARGIN)  # 8.4 m wide: too narrow for a 7 m-radius U-turn
    with pytest.raises(PlanningError, match="no path"):
        LocalPathPlanner(PlannerConfig(kind="dubins", max_iterations=3000), seed=2).plan([15, 0, 0], [[5, 0, math.pi]], region)
    plan = LocalPathPlanner(PlannerConfig(kind="dubins", fallback_kind="reeds_shepp"), seed=2).plan(
        [15, 0, 0], [[5, 0, math.pi]], region)
    assert np.any(plan.direction < 0)  # a three-point turn: some of it in reverse
    assert np.max(np.abs(plan.curvature)) <= 1 / 7.0 + 1e-4
    assert all(shapely.contains_xy(region, x, y) for x, y, _ in plan.poses)


@pytest.mark.parametrize("kind", ["se2", "dubins"])
def test_a_goal_heading_due_west_is_reachable(kind):
    # atan2 gives exactly +pi for a path due west; OMPL's SO(2) bounds are [-pi, pi): the planner
    # must wrap it, or the goal is never valid (a left turn onto a westbound walk failed this way).
    region = LineString([(0, 0), (0, 20), (-25, 20)]).buffer(4.0, join_style="mitre")
    cfg = PlannerConfig(kind=kind, turning_radius=5.0)
    plan = LocalPathPlanner(cfg, seed=2).plan([0, 0, math.pi / 2], [[-22, 20, math.pi]], region)
    end = plan.poses[-1]
    assert math.hypot(end[0] + 22, end[1] - 20) < 0.5
    assert abs(math.remainder(end[2] - math.pi, 2 * math.pi)) < 0.5


def test_a_goal_out_of_forward_reach_is_moved_sideways_before_reversing():
    # The Navlab 0.6 m right of the centre, heading 8° to the left, 7 m before a lane point 1.5 m
    # right of the centre (a landmark fix moved the estimate sideways near the end of a unit): no
    # forward curve of 7 m radius reaches it inside the shrunk road.
    from shapely.geometry import box

    region = box(-20, -3, 40, 3).buffer(-1.2)
    fx = (0.0, 1.5, 3.0)
    cfg = PlannerConfig(kind="dubins", turning_radius=7.0, footprint_x=fx, fallback_kind="reeds_shepp",
                        relax_fractions=(0.25, 0.5, 0.75, 1.0), max_iterations=3000)
    start, goal = [0.0, -0.63, math.radians(8.0)], [7.1, -1.48, 0.0]
    # OMPL's RNG is seeded once per process, so its state here depends on the tests before: give the
    # reversing search the PILOT's full budget (short ones fail about one time in five).
    full = cfg.model_copy(update={"max_iterations": 20000})
    exact = LocalPathPlanner(full, seed=2).plan(start, [goal], region)
    assert np.any(exact.direction < 0)  # a goal it must meet exactly (a stop): it shuffles, reversing
    assert np.allclose(exact.poses[-1][:2], goal[:2], atol=0.3)
    relaxed = LocalPathPlanner(cfg, seed=2).plan(start, [goal], region, relax_goal=True)
    assert np.all(relaxed.direction > 0)  # a goal it drives through: forward only, to a point beside it
    end = relaxed.poses[-1]
    assert abs(end[0] - 7.1) < 0.3 and -1.48 < end[1] < -0.63 and abs(math.remainder(end[2], 2 * math.pi)) < 0.05
    assert relaxed.length < exact.length
    for x, y, yaw in relaxed.poses:
        assert all(shapely.contains_xy(region, x + d * math.cos(yaw), y + d * math.sin(yaw)) for d in fx)
    assert np.max(np.abs(relaxed.curvature)) <= 1 / 7.0 + 1e-4
    # Forward only (the PILOT first searches every region it has forward): no path, a clear error.
    with pytest.raises(PlanningError, match="no path"):
        LocalPathPlanner(cfg, seed=2).plan(start, [goal], region, reverse=False)
    assert np.any(LocalPathPlanner(full, seed=2).plan_reversing(start, [goal], region).direction < 0)
    with pytest.raises(PlanningError, match="no reversing model"):
        LocalPathPlanner(PlannerConfig(kind="dubins"), seed=2).plan_reversing(start, [goal], region)
