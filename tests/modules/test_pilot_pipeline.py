"""PILOT pipeline core (Figure 6) without a network: units posted ahead, plans extended while driving."""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString

from modules.helm.tracker import PathTracker, TrackerConfig
from modules.pilot.driving_units import DrivingUnitConfig
from modules.pilot.local_path_constraints import NavigatorConfig, local_constraints
from modules.pilot.planner import LocalPathPlanner, PlannerConfig
from modules.pilot.polyline import PathLine
from modules.pilot.segment import SegmentDriver, SegmentGeometry, map_region
from modules.pilot.speed_profile import speed_profile


def _unicycle(state, v, k, dt):
    x, y, th = state
    for _ in range(5):
        h = dt / 5
        x += v * math.cos(th) * h
        y += v * math.sin(th) * h
        th += v * k * h
    return np.array([x, y, th])


def _segment(points, width=6.0):
    path = PathLine.from_points(points)
    region = map_region(path.xy, width, [], [])
    end = path.point_at(path.length)
    return SegmentGeometry(path=path, region=region, objects=(), exit_point=(end[0], end[1]), exit_radius=1.0)


def _drive(geom, *, use_perception, perception_delay=0.0, kind="dubins", max_steps=6000):
    drv = SegmentDriver(geom, DrivingUnitConfig(unit_length=6.0), lookahead_m=12.0, perception_timeout_s=100.0,
                        use_perception=use_perception)
    planner = LocalPathPlanner(PlannerConfig(kind=kind), seed=1)
    tracker = PathTracker(TrackerConfig(max_curvature=1 / 7.0, max_speed=1.5))
    state = np.array([*geom.path.point_at(0.0), geom.path.heading_at(0.0)])
    t, dt = 0.0, 0.1
    in_flight_max = 0
    plan_log = []  # (vehicle s, planned-through unit, far s of plan)
    for _ in range(max_steps):
        drv.update_progress(state[:2])
        for i in drv.units_to_post(t):
            if not use_perception:
                drv.resolve(i, None, False, "dead reckoning")
        posted = [i for i, u in enumerate(drv.units) if u.phase == "posted"]
        in_flight_max = max(in_flight_max, len(posted))
        for i in posted:  # PERCEPTION answers after a delay with the region it saw
            if t - drv.units[i].posted_at >= perception_delay:
                drv.resolve(i, drv.units[i].span.region.buffer(-0.2), True, "perceived")
        if drv.needs_plan():
            regions, far_s, perceived, idx = drv.plan_inputs()
            cons = local_constraints(geom.path, regions, far_s, perceived, keep="right", cfg=NavigatorConfig(margin=1.0))
            goals = [g for g, s in zip(cons.goals, cons.goal_s) if s > drv.s_vehicle + 2.0] or [cons.goals[-1]]
            path = planner.plan(state, goals, cons.region)
            last = drv.units[idx[-1]].span.last
            tracker.set_plan(path.poses, speed_profile(path.s, path.curvature, path.direction, 1.5, stop_at_end=last))
            drv.mark_planned(idx[-1])
            plan_log.append((drv.s_vehicle, idx[-1], far_s[-1]))
        if drv.exited(state[:2]):
            return drv, plan_log, in_flight_max, True, t
        cmd = tracker.command(state, dt)
        state = _unicycle(state, cmd.speed, cmd.curvature, dt)
        t += dt
    return drv, plan_log, in_flight_max, False, t


def test_dead_reckoning_pipeline_reaches_exit_planning_ahead_of_the_vehicle():
    geom = _segment([(0, 0), (30, 0), (30, 30)], width=8.0)
    drv, plans, in_flight, ok, t = _drive(geom, use_perception=False)
    assert ok, "the vehicle never reached the segment exit"
    assert len(plans) >= 3  # the plan was extended unit by unit while driving
    # Each new plan was made while the vehicle was still in an earlier unit than the plan's newest.
    assert all(s_vehicle < far_s for s_vehicle, _, far_s in plans)
    assert sum(1 for s_vehicle, k, _ in plans if drv.units[k].span.s_start > s_vehicle) >= 2
    assert [k for _, k, _ in plans] == sorted(k for _, k, _ in plans)


def test_perception_pipeline_keeps_one_unit_in_flight_and_uses_perceived_regions():
    geom = _segment([(0, 0), (40, 0)], width=6.0)
    drv, plans, in_flight, ok, t = _drive(geom, use_perception=True, perception_delay=1.5)
    assert ok
    assert in_flight == 1
    assert drv.perceived_count == len(drv.units)
    assert all(u.perceived and u.region.area < u.span.region.area for u in drv.units)


def test_units_wait_for_the_previous_one_and_for_the_lookahead():
    geom = _segment([(0, 0), (60, 0)])
    drv = SegmentDriver(geom, DrivingUnitConfig(unit_length=6.0), lookahead_m=12.0, use_perception=True)
    assert drv.units_to_post(0.0) == [0]
    assert drv.units_to_post(0.1) == []  # unit 0 not answered yet
    drv.resolve(0, None, False, "perception timeout")
    assert drv.units[0].region is drv.units[0].span.region  # fell back to the map's region
    assert drv.units_to_post(0.2) == [1]
    drv.resolve(1, None, False, "t")
    drv.units_to_post(0.3)
    drv.resolve(2, None, False, "t")
    assert drv.units_to_post(0.4) == []  # unit 3 starts 18 m ahead: beyond the 12 m look-ahead
    drv.update_progress(np.array([8.0, 0.0]))
    assert drv.units_to_post(0.5) == [3]
    assert drv.overdue(0.5 + drv.perception_timeout_s) == [3]


def test_perceived_region_rules_inside_the_view_frame_and_the_map_fills_the_rest():
    from shapely.geometry import box

    from modules.pilot.segment import fuse_regions

    map_unit = box(0, -1.5, 6, 1.5)  # the map's walk, 3 m wide
    view = box(1, -3, 4, 3)  # the sensor saw x ∈ [1, 4]
    seen = box(1, -1.2, 4, 1.0)  # ... and found the walk a little narrower there
    fused = fuse_regions(seen, view, map_unit)
    assert fused.contains(box(4.1, -1.4, 6, 1.4))  # beyond the view: the map's region
    assert not fused.contains(box(2, 1.1, 3, 1.4))  # inside the view: only what was seen
    assert fused.contains(box(1.1, -1.1, 3.9, 0.9))
    assert fuse_regions(seen, None, map_unit).contains(box(4.5, -1.4, 6, 1.4))


def test_a_segment_ends_at_the_last_goal_when_the_region_stops_short_of_the_exit():
    geom = _segment([(0.0, 0.0), (20.0, 0.0)])
    drv = SegmentDriver(geom, DrivingUnitConfig(unit_length=6.0), lookahead_m=12.0, use_perception=False)
    last = len(drv.units) - 1
    assert drv.goal_meets_exit(np.array([19.5, 0.0]), 19.5)
    assert not drv.goal_meets_exit(np.array([17.0, 0.0]), 17.0)  # exit radius 1 m: s ≥ 19 or within 1 m
    drv.mark_planned(last - 1, 12.0)
    assert drv.final_goal_s is None  # a plan short of the last unit says nothing about the end
    drv.mark_planned(last, 17.0)
    drv.update_progress(np.array([16.0, 0.0]))
    assert not drv.at_final_goal() and not drv.exited(np.array([16.0, 0.0]))
    drv.update_progress(np.array([16.7, 0.1]))
    assert drv.at_final_goal() and not drv.exited(np.array([16.7, 0.1]))


def test_a_plan_carries_the_newest_capture_of_the_perceived_units_it_is_built_on():
    geom = _segment([(0, 0), (60, 0)])
    drv = SegmentDriver(geom, DrivingUnitConfig(unit_length=6.0), lookahead_m=30.0, use_perception=True)
    drv.units_to_post(0.0)
    drv.resolve(0, drv.units[0].span.region.buffer(-0.5), True, "perceived", sensed_at=3.25)
    drv.units_to_post(0.1)
    drv.resolve(1, None, False, "perception timeout", sensed_at=4.0)  # not perceived: its capture is not used
    drv.units_to_post(0.2)
    drv.resolve(2, drv.units[2].span.region.buffer(-0.5), True, "perceived", sensed_at=5.5)
    assert drv.sensed_at([0, 1]) == 3.25 and drv.sensed_at([0, 1, 2]) == 5.5 and drv.sensed_at([1]) is None
