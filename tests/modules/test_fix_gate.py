"""The fix gate the PILOT and EDDIE's navigator share: a road-edge fix whose heading is far off a
confident estimate is refused and leaves it unchanged, consistent fixes pass, and refusals in a row
doubt the estimate until consistent fixes get in again."""

import math

import numpy as np

from modules.pilot.config import PilotConfig
from modules.pilot.fix_gate import DOUBT_SIGMA_YAW, FIX_GATE, FixGate
from modules.pilot.kalman import FixRefused, LineFix, PoseFilter


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
    # the estimate believes 1° but the road truly runs 0.12 rad off it: every true fix is refused at first
    f, gate = _confident(), FixGate()
    used_after = None
    for i in range(12):
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
