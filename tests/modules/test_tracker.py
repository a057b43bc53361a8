"""HELM tracker: pure pursuit converges onto a straight line and an arc from an offset start, stops at the end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.helm.tracker import PathTracker, TrackerConfig, TrackerError


def _unicycle(state: np.ndarray, v: float, kappa: float, dt: float) -> np.ndarray:
    """Advance (x [m], y [m], yaw [rad]) by speed v [m/s] and curvature kappa [1/m] for dt [s]."""
    x, y, th = state
    n = 10
    h = dt / n
    for _ in range(n):
        x += v * math.cos(th) * h
        y += v * math.sin(th) * h
        th += v * kappa * h
    return np.array([x, y, th])


def _drive(tracker: PathTracker, start: np.ndarray, steps: int = 4000, dt: float = 0.1):
    state = start.copy()
    log = []
    for _ in range(steps):
        cmd = tracker.command(state, dt)
        log.append((state.copy(), cmd))
        if cmd.done:
            break
        state = _unicycle(state, cmd.speed, cmd.curvature, dt)
    return state, log


def test_converges_onto_straight_line_and_stops_at_end():
    xs = np.arange(0.0, 40.0 + 1e-9, 0.25)
    poses = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)
    speeds = np.full(len(xs), 1.5)
    speeds[-1] = 0.0
    tr = PathTracker(TrackerConfig(max_curvature=1 / 7.0, max_speed=2.0))
    tr.set_plan(poses, speeds)
    final, log = _drive(tr, np.array([0.0, 1.5, 0.3]))
    assert log[-1][1].done
    cross_late = [abs(c.cross_track) for st, c in log if st[0] > 25.0]
    assert cross_late and max(cross_late) < 0.05
    assert abs(final[0] - 40.0) < 0.3 and abs(final[1]) < 0.05
    assert max(abs(c.curvature) for _, c in log) <= 1 / 7.0 + 1e-12
    assert max(c.speed for _, c in log) <= 2.0 + 1e-9
    # Braking to rest at the end: near the end, speed never exceeds sqrt(2·decel·remaining).
    near_end = [c for _, c in log if not c.done and c.remaining < 2.0]
    assert near_end and all(c.speed <= math.sqrt(2 * 1.0 * c.remaining) + 1e-9 for c in near_end)
    assert near_end[-1].speed < 1.0


def test_converges_onto_arc_from_offset_start():
    r = 10.0
    th = np.arange(0.0, math.pi, 0.25 / r)
    poses = np.stack([r * np.sin(th), r - r * np.cos(th), th], axis=1)  # CCW circle centred (0, r)
    speeds = np.full(len(th), 1.0)
    tr = PathTracker(TrackerConfig(max_curvature=1 / 7.0))
    tr.set_plan(poses, speeds)
    final, log = _drive(tr, np.array([0.0, -1.0, 0.0]))
    late = [abs(c.cross_track) for st, c in log if math.atan2(st[0], r - st[1]) > 1.5]
    assert late and max(late) < 0.15
    assert log[-1][1].done


def test_no_plan_means_stop_and_bad_plan_rejected():
    tr = PathTracker()
    cmd = tr.command(np.zeros(3), 0.1)
    assert cmd.speed == 0.0 and cmd.done
    with pytest.raises(TrackerError):
        tr.set_plan(np.zeros((1, 3)), np.zeros(1))
    with pytest.raises(TrackerError):
        tr.set_plan(np.zeros((3, 3)), np.zeros(2))
    with pytest.raises(TrackerError):
        tr.set_plan(np.array([[0, 0, 0], [1, np.nan, 0]]), np.zeros(2))


def test_reverse_plan_drives_backwards():
    xs = np.arange(0.0, -10.0 - 1e-9, -0.25)
    poses = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)  # facing +x, moving -x
    speeds = np.full(len(xs), -0.8)
    tr = PathTracker()
    tr.set_plan(poses, speeds)
    final, log = _drive(tr, np.array([0.0, 0.4, 0.0]))
    assert all(c.speed <= 0.0 for _, c in log)
    assert log[-1][1].done and final[0] < -9.5 and abs(final[1]) < 0.1


def test_skid_steer_turns_in_place_at_a_corner():
    # An L-shaped polyline plan (Terregator, SE(2) planner): along +x, then along +y.
    a = np.stack([np.arange(0, 5.01, 0.25), np.zeros(21), np.zeros(21)], axis=1)
    b = np.stack([np.full(20, 5.0), np.arange(0.25, 5.01, 0.25), np.full(20, math.pi / 2)], axis=1)
    poses = np.vstack([a, b])
    tr = PathTracker(TrackerConfig(max_curvature=2.0, max_speed=0.5, turn_in_place_angle=math.radians(60),
                                   lookahead_base=0.8, lookahead_gain=0.5))
    tr.set_plan(poses, np.full(len(poses), 0.5))
    state = np.array([4.9, 0.0, 0.0])
    turned = False
    for _ in range(2000):
        cmd = tr.command(state, 0.1)
        if cmd.done:
            break
        if cmd.turn_rate is not None:
            turned = True
            assert cmd.speed == 0.0
            state = state + np.array([0.0, 0.0, cmd.turn_rate * 0.1])
        else:
            state = _unicycle(state, cmd.speed, cmd.curvature, 0.1)
    assert turned and cmd.done
    assert abs(state[0] - 5.0) < 0.3 and abs(state[1] - 5.0) < 0.3


def _drive_kinematics(tracker, params, start, steps=6000, dt=0.05, control_every=2):
    """Close the loop through the simulator's vehicle model (lags, rate limits) with control at dt·control_every."""
    from wire.drive import DriveCommand
    from vehicle_sim.kinematics import VehicleState, step

    st = VehicleState(x=start[0], y=start[1], yaw=start[2])
    cmd = DriveCommand(speed=0.0)
    log = []
    for k in range(steps):
        if k % control_every == 0:
            tc = tracker.command(np.array([st.x, st.y, st.yaw]), dt * control_every)
            log.append(((st.x, st.y, st.yaw, st.v), tc))
            if tc.done and abs(st.v) < 0.01:
                break
            cmd = DriveCommand(speed=tc.speed, curvature=tc.curvature, turn_rate=tc.turn_rate)
        st = step(st, cmd, dt, params)
    return st, log


def test_navlab_model_converges_onto_straight_road_and_stops():
    from vehicle_sim.kinematics import NAVLAB

    xs = np.arange(0.0, 120.0 + 1e-9, 0.25)
    poses = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)
    speeds = np.full(len(xs), 4.0)
    speeds[-1] = 0.0
    tr = PathTracker(TrackerConfig(max_curvature=1 / 7.0, max_speed=7.5, lookahead_base=3.0, lookahead_gain=1.0,
                                   lookahead_max=10.0, max_accel=0.8, max_decel=1.5, speed_lag=0.4))
    tr.set_plan(poses, speeds)
    final, log = _drive_kinematics(tr, NAVLAB, (0.0, 1.5, 0.1))
    late = [abs(c.cross_track) for (x, *_), c in log if x > 60.0 and not c.done]
    assert late and max(late) < 0.1
    assert abs(final.x - 120.0) < 0.5 and abs(final.y) < 0.05 and abs(final.v) < 0.05  # stopped at the end


def test_navlab_model_converges_onto_an_arc_at_the_turning_limit():
    from vehicle_sim.kinematics import NAVLAB

    r = 9.0  # a curve just wider than the 7 m minimum turning radius
    th = np.arange(0.0, 1.5 * math.pi, 0.25 / r)
    poses = np.stack([r * np.sin(th), r - r * np.cos(th), th], axis=1)
    tr = PathTracker(TrackerConfig(max_curvature=1 / 7.0, max_speed=3.0, lookahead_base=3.0, lookahead_gain=0.5))
    tr.set_plan(poses, np.full(len(th), 2.0))
    final, log = _drive_kinematics(tr, NAVLAB, (0.0, -1.0, 0.0))
    late = [abs(c.cross_track) for (x, y, *_), c in log if math.atan2(x, r - y) > 2.0]
    assert late and max(late) < 0.3


def test_terregator_model_follows_a_polyline_with_turns_in_place():
    from vehicle_sim.kinematics import TERREGATOR

    a = np.stack([np.arange(0, 6.01, 0.25), np.zeros(25), np.zeros(25)], axis=1)
    b = np.stack([np.full(24, 6.0), np.arange(0.25, 6.01, 0.25), np.full(24, math.pi / 2)], axis=1)
    poses = np.vstack([a, b])
    tr = PathTracker(TrackerConfig(max_curvature=2.0, max_speed=1.0, lookahead_base=1.0, lookahead_gain=0.8,
                                   max_accel=0.4, turn_in_place_angle=math.radians(50), max_turn_rate=0.4))
    tr.set_plan(poses, np.full(len(poses), 0.8))
    final, log = _drive_kinematics(tr, TERREGATOR, (0.0, 0.3, 0.0))
    assert math.hypot(final.x - 6.0, final.y - 6.0) < 0.4
    assert max(abs(c.cross_track) for _, c in log) < 0.8


def test_command_horizon_reaches_the_lookahead_point_but_never_past_the_plan_end():
    cfg = TrackerConfig(max_speed=1.0, max_accel=10.0, lookahead_base=1.0, lookahead_gain=1.0, lookahead_max=5.0)
    xs = np.linspace(0.0, 20.0, 81)
    poses = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)
    tr = PathTracker(cfg)
    tr.set_plan(poses, np.full(len(xs), 1.0))
    mid = tr.command(np.array([5.0, 0.0, 0.0]), 1.0)
    assert mid.speed == pytest.approx(1.0)
    assert mid.horizon == pytest.approx((1.0 + 1.0 * 1.0) / 1.0)  # lookahead 2 m at 1 m/s
    near_end = tr.command(np.array([19.5, 0.0, 0.0]), 0.1)
    assert not near_end.done and near_end.speed > 0.0
    assert near_end.speed * near_end.horizon <= 0.5 - cfg.goal_tolerance + 1e-9
    assert tr.command(np.array([20.5, 0.0, 0.0]), 0.1).horizon == math.inf  # done: a stop holds


def test_helm_commands_are_timed_so_a_late_one_does_not_trip_the_watchdog():
    from codger.helm.helm import Helm, HelmConfig
    from wire.drive import MAX_COMMAND_DURATION

    helm = Helm.__new__(Helm)
    helm.cfg = HelmConfig(control_hz=10.0, max_hold_s=2.0)
    assert helm.command_duration(math.inf, moving=False) == MAX_COMMAND_DURATION
    assert helm.command_duration(0.01, moving=True) == pytest.approx(0.15)  # at least 1.5 control periods
    assert helm.command_duration(1.2, moving=True) == pytest.approx(1.2)
    assert helm.command_duration(50.0, moving=True) == pytest.approx(2.0)


def test_a_late_arc_command_lapses_before_it_turns_the_vehicle_past_the_plan():
    # heading 0.3 rad off a straight plan: pure pursuit's arc to the lookahead point turns the heading
    # by twice its bearing, so held all the way it ends ~0.3 rad off on the other side (the weave)
    xs = np.linspace(0.0, 20.0, 81)
    plan = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)

    def command(overshoot: float | None):
        cfg = TrackerConfig(max_speed=1.0, max_accel=10.0, max_curvature=2.0, lookahead_base=1.0, lookahead_gain=1.0,
                            lookahead_max=5.0, overshoot=overshoot)
        tr = PathTracker(cfg)
        tr.set_plan(plan, np.full(len(xs), 1.0))
        return tr.command(np.array([5.0, 0.0, 0.3]), 1.0)

    cmd = command(0.1)
    assert cmd.speed > 0.0 and cmd.curvature < 0.0

    def heading_after(t: float) -> float:  # the arc held for t [s]
        return 0.3 + cmd.speed * cmd.curvature * t

    reach_time = (1.0 + 1.0 * cmd.speed) / cmd.speed
    assert heading_after(reach_time) < -0.2  # held to the lookahead point: turned past the plan
    assert cmd.horizon < reach_time
    assert abs(heading_after(cmd.horizon)) <= 0.1 + 0.02  # lapses about aligned with the plan
    assert command(None).horizon == pytest.approx(reach_time)  # unset: the arc holds to the lookahead point


def test_predict_pose_drives_exactly_along_the_arc_or_turns_on_the_spot():
    from modules.helm.tracker import Actuation, predict_pose

    start = np.array([1.0, 2.0, 0.4])
    for act in (Actuation(0.8, 0.0), Actuation(0.8, 0.5), Actuation(-0.5, -0.3)):
        fine = start
        for _ in range(200):  # the arc in 2,000 Euler steps
            fine = _unicycle(fine, act.speed, act.curvature, 0.01)
        np.testing.assert_allclose(predict_pose(start, act, 2.0), fine, atol=5e-4)  # Euler's error
    np.testing.assert_allclose(predict_pose(start, Actuation(0.0, 0.0, 0.4), 0.5), [1.0, 2.0, 0.6])


def test_rollout_gives_the_commands_an_on_time_tracker_would_send_and_leaves_the_tracker_as_it_was():
    from modules.helm.tracker import Actuation, predict_pose, rollout

    xs = np.linspace(0.0, 30.0, 121)
    plan = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)
    cfg = TrackerConfig(max_speed=1.0, max_accel=0.5, max_curvature=2.0, lookahead_base=1.0, lookahead_gain=0.8)
    tr = PathTracker(cfg)
    tr.set_plan(plan, np.full(len(xs), 1.0))
    start = np.array([2.0, 0.6, 0.2])  # left of the plan, heading away from it
    first = tr.command(start, 0.1)
    before = tr.fork()
    shape = lambda c, dt: Actuation(c.speed, c.curvature, c.turn_rate)  # noqa: E731 - the driver sends what the tracker says
    steps = rollout(tr, start, Actuation(first.speed, first.curvature), shape, 0.1, 2.0)
    assert sum(d for _, d in steps) == pytest.approx(2.0)  # the horizon, after the command in hand
    # the same as a twin tracker asked every period at the pose its own commands drive to
    twin = PathTracker(cfg)
    twin.set_plan(plan, np.full(len(xs), 1.0))
    cmd, p, sent = twin.command(start, 0.1), start, []
    for _ in range(20):
        p = predict_pose(p, Actuation(cmd.speed, cmd.curvature), 0.1)
        cmd = twin.command(p, 0.1)
        sent.append((cmd.speed, cmd.curvature))
    merged = [(a.speed, a.curvature) for a, d in steps for _ in range(int(round(d / 0.1)))]
    np.testing.assert_allclose(merged, sent, atol=2e-3)
    assert p[1] < start[1] and p[2] < start[2]  # turning back towards the plan
    # the tracker itself did not move on (progress, speed ramp): it answers as a copy taken before the rollout
    again, ref = tr.command(start, 0.1), before.command(start, 0.1)
    assert (again.speed, again.curvature, again.horizon) == (ref.speed, ref.curvature, ref.horizon)


def test_rollout_stops_at_the_plans_end_and_at_a_stop():
    from modules.helm.tracker import Actuation, rollout

    xs = np.linspace(0.0, 1.0, 5)
    plan = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1)
    tr = PathTracker(TrackerConfig(max_speed=1.0, max_accel=10.0))
    tr.set_plan(plan, np.full(len(xs), 1.0))
    shape = lambda c, dt: Actuation(c.speed, c.curvature, c.turn_rate)  # noqa: E731
    steps = rollout(tr, np.zeros(3), Actuation(0.5, 0.0), shape, 0.1, 5.0)
    assert 0.5 < sum(d for _, d in steps) < 3.0  # ends where the plan ends, not at the horizon
    assert rollout(tr, np.zeros(3), Actuation(0.5, 0.0), lambda c, dt: Actuation(0.0, 0.0), 0.1, 5.0) == []


def test_lookahead_sends_the_rest_of_its_prediction_and_predicts_again_when_old_off_or_on_a_new_plan():
    from modules.helm.tracker import Actuation, Lookahead, predict_pose

    xs = np.linspace(0.0, 40.0, 161)
    plan = np.stack([xs, 0.5 * np.sin(xs / 4.0), np.zeros_like(xs)], axis=1)
    plan[:, 2] = np.gradient(plan[:, 1], xs)
    cfg = TrackerConfig(max_speed=1.0, max_accel=0.5, max_curvature=2.0, lookahead_base=1.0, lookahead_gain=0.8)
    tr = PathTracker(cfg)
    tr.set_plan(plan, np.full(len(xs), 1.0))
    look = Lookahead(0.1, 2.0, every=0.5)
    shape = lambda c, dt: Actuation(c.speed, c.curvature, c.turn_rate)  # noqa: E731
    pose, t, sent = np.array([0.0, 0.0, 0.0]), 0.0, []
    for _ in range(30):  # on time, the vehicle where the predictions put it: 3 s sim, 30 commands
        c = tr.command(pose, 0.1)
        first = Actuation(c.speed, c.curvature)
        steps = look.steps(t, tr, pose, first, shape)
        sent.append(sum(d for _, d in steps))
        pose, t = predict_pose(pose, first, 0.1), t + 0.1
    assert look.predictions == 6  # one each 0.5 s sim, not one a command
    assert min(sent) >= 1.5 - 1e-6 and max(sent) == pytest.approx(2.0)  # at least the horizon less the reuse age
    # the vehicle pushed off the predicted course: the command in hand differs from the prediction, which is made again
    off = pose + np.array([0.0, 0.8, 0.4])
    c = tr.command(off, 0.1)
    look.steps(t + 0.1, tr, off, Actuation(c.speed, c.curvature), shape)
    assert look.predictions == 7
    # a new plan: predicted afresh at once
    tr.set_plan(plan + np.array([0.0, 1.0, 0.0]), np.full(len(xs), 1.0))
    c = tr.command(off, 0.1)
    look.steps(t + 0.2, tr, off, Actuation(c.speed, c.curvature), shape)
    assert look.predictions == 8
