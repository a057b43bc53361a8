"""The fix gate the PILOT and EDDIE's navigator share: a road-edge fix whose heading is far off a
confident estimate is refused and leaves it unchanged, consistent fixes pass, and refusals in a row
doubt the estimate until consistent fixes get in again."""

import math

import numpy as np

from modules.pilot.config import PilotConfig
from modules.pilot.fix_gate import DOUBT_SIGMA_YAW, DOUBT_STEP_M, FIX_GATE, FixGate
from modules.pilot.kalman import FixRefused, LineFix, PointFix, PoseFilter


def _confident() -> PoseFilter:
    # heading known to 1°, position to 0.3 m: the PILOT after a run of good fixes
    return PoseFilter(np.array([10.0, 0.0, 0.0]), np.diag([0.3**2, 0.3**2, math.radians(1.0) ** 2]), gate=FIX_GATE)


def _edge(yaw: float) -> LineFix:
    # a road edge along +x one metre to the left, its direction seen to within 0.02 rad
    return LineFix(point=np.array([0.0, 1.0]), angle=0.0, cross_var=0.1**2, yaw=yaw, yaw_var=0.02**2)


def test_the_pilot_gates_perception_fixes_as_the_navigator_does():
    assert PilotConfig().fix_gate == FIX_GATE


def test_a_road_edge_fix_whose_heading_is_far_off_is_refused_and_leaves_the_estimate_unchanged():
    f, gate = _confident(), FixGate()
    before_pose, before_cov = f.pose.copy(), f.cov.copy()
    try:
        f.update_line(_edge(0.165))  # the fix that turned CODGER's estimate at Oak (compare grid E, amv seed 0)
    except FixRefused:
        gate.on_refused(f)
    else:
        raise AssertionError("a heading 0.165 rad off a 1° estimate must be refused")
    assert gate.refused == 1 and gate.used == 0
    assert np.array_equal(f.pose, before_pose) and np.array_equal(f.cov, before_cov)  # one refusal: no doubt yet
    f.update_line(_edge(0.01))  # a consistent one passes
    gate.on_used()
    assert gate.refused_in_row == 0 and abs(f.pose[2]) < 0.02


def test_refusals_in_a_row_doubt_an_estimate_that_drifted_until_consistent_fixes_get_in():
    # the estimate believes 1° but the road truly runs 0.12 rad off it: every true fix is refused at first;
    # the vehicle drives 1 m along the road between fixes
    f, gate = _confident(), FixGate()
    used_after = None
    for i in range(12):
        if i:
            f.predict(np.array([1.0, 0.0, 0.0]))
        try:
            f.update_line(_edge(0.12))
        except FixRefused:
            gate.on_refused(f)
            continue
        gate.on_used()
        used_after = i
        break
    assert used_after is not None and used_after >= 1, "the first refusal must not doubt; later ones must let it in"
    assert gate.refused == used_after and gate.refused_in_row == 0
    assert abs(f.pose[2] - 0.12) < 0.05
    assert math.sqrt(f.cov[2, 2]) <= DOUBT_SIGMA_YAW + 1e-9


def _wrong_point_fix(f: PoseFilter) -> PointFix:
    # a landmark matched to the wrong object: 4 m off to the left and 8° off, claimed to 0.2 m / 1°
    x, y, yaw = f.pose
    c, s = math.cos(yaw), math.sin(yaw)
    return PointFix(pose=np.array([x - 4.0 * s, y + 4.0 * c, yaw + math.radians(8.0)]),
                    cov=np.diag([0.2**2, 0.2**2, math.radians(1.0) ** 2]))


def _offer(f: PoseFilter, gate: FixGate, fix: PointFix) -> bool:
    try:
        f.update_point(fix)
    except FixRefused:
        gate.on_refused(f)
        return False
    gate.on_used()
    return True


def test_many_frames_of_one_scene_from_one_place_doubt_the_estimate_once():
    # EDDIE on suburb_4: the vehicle crept up to a crossing and the same wrong match came several times a second;
    # when every refusal doubled the covariance, the wrong fix got in within a few frames
    f, gate = _confident(), FixGate()
    before = f.pose.copy()
    taken = [_offer(f, gate, _wrong_point_fix(f)) for _ in range(30)]
    assert not any(taken), f"a wrong fix from one place got in at frame {taken.index(True)}"
    assert gate.doubled == 1 and gate.refused_in_row == 30
    assert np.array_equal(f.pose, before)


def test_refusals_from_places_apart_go_on_doubting_until_the_fix_gets_in():
    # the same fix seen again and again as the vehicle drives on is evidence that the estimate is wrong
    f, gate = _confident(), FixGate()
    for place in range(1, 20):
        if any(_offer(f, gate, _wrong_point_fix(f)) for _ in range(3)):
            break
        assert gate.doubled == place  # three frames from one place, one doubling
        f.predict(np.array([DOUBT_STEP_M + 0.05, 0.0, 0.0]))
    else:
        raise AssertionError("a fix seen from 19 places apart never got in")
    assert gate.used == 1 and gate.doubled == 0 and place >= 2
