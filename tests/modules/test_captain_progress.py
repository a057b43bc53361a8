"""A step's progress along its route (both mission services): done and left, the time since progress, a replan no progress."""

import math

import pytest

from modules.captain.progress import RouteProgress


def test_progress_along_an_l_shaped_route_counts_getting_farther_not_getting_closer():
    t = RouteProgress(0, [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], now=5.0)
    assert t.since(7.0) == 2.0  # since the step started
    assert t.note(8.0, t.left((1.0, 0.3))) and t.since(9.0) == 1.0
    # 0.3 m farther is not progress (0.5 m is); the belief 2 m off to the side projects where it projects
    assert not t.note(9.0, t.left((1.3, 2.0)))
    assert t.note(10.0, t.left((6.0, -2.0))) and t.best_left == pytest.approx(14.0)
    # the route leads away from the goal for a while: nearer the goal in a straight line is not progress
    assert not t.note(11.0, t.left((5.0, 4.0)))
    r = t.report(12.0, (9.0, 0.0, math.pi / 2), "planning")
    assert (r.route_done_m, r.route_left_m, r.since_progress_s, r.waiting) == (pytest.approx(9.0), pytest.approx(11.0), 2.0, "planning")
    assert (r.pose.x, r.pose.y, r.pose.yaw, r.step_index, r.sim_time_s) == (9.0, 0.0, math.pi / 2, 0, 12.0)
    # without a pose: the last look's figures
    assert t.report(12.0, None).route_left_m == pytest.approx(t.last_left) and t.report(12.0, None).pose is None


def test_a_replan_is_a_baseline_not_progress():
    t = RouteProgress(1, [(0.0, 0.0), (20.0, 0.0)], now=0.0)
    t.note(1.0, t.left((5.0, 0.0)))
    t.reroute([(5.0, 0.0), (5.0, 5.0), (20.0, 5.0)])  # a detour: 20 m left where 15 were
    assert not t.note(2.0, t.left((5.0, 0.0))) and t.since(3.0) == 2.0
    assert t.note(4.0, t.left((5.0, 4.0))) and t.since(4.0) == 0.0


def test_at_rest_once_still_for_the_hold_time_turning_on_the_spot_is_not_rest():
    from modules.captain.arrival import REST_HOLD_S, RestDetector

    r = RestDetector()
    for k in range(5):  # 0.5 m/s for 1 s, a pose every 0.25 s
        r.feed(k * 0.25, 0.125 * k, 0.0, 0.0)
    assert not r.at_rest(1.0)
    r.feed(1.25, 0.5, 0.0, 0.0)  # stopped at 0.5 m since 1.0 s
    r.feed(1.25, 0.5, 0.0, 0.0)  # the same period again: no new motion
    assert r.still_since == 1.0 and not r.at_rest(1.0 + REST_HOLD_S - 0.01) and r.at_rest(1.0 + REST_HOLD_S)
    r.feed(2.0, 0.5, 0.0, 0.1)  # turning on the spot (0.13 rad/s): moving again
    assert r.still_since is None and not r.at_rest(5.0)
    r.feed(2.5, 0.501, 0.0, 0.1)  # 2 mm/s creep counts as still
    assert r.still_since == 2.0 and r.at_rest(3.0)
