"""POSITION ESTIMATOR filter: odometry grows uncertainty, point fixes correct all, line fixes only across."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.pilot.kalman import EstimatorError, LineFix, OdometryNoise, PointFix, PoseFilter
from wire.se2 import compose


def test_odometry_prediction_composes_and_grows_covariance():
    f = PoseFilter(np.array([1.0, 2.0, math.pi / 2]), np.eye(3) * 1e-4)
    p0 = np.trace(f.cov)
    for _ in range(10):
        f.predict(np.array([1.0, 0.0, 0.0]))
    assert np.allclose(f.pose, [1.0, 12.0, math.pi / 2], atol=1e-9)
    assert np.trace(f.cov) > p0
    assert f.distance_m == pytest.approx(10.0)


def test_point_fix_corrects_both_components_and_converges():
    rng = np.random.default_rng(7)
    truth = np.array([0.0, 0.0, 0.0])
    f = PoseFilter(np.array([2.0, -1.5, 0.2]), np.diag([4.0, 4.0, 0.2]))
    r = np.diag([0.05**2, 0.05**2, 0.01**2])
    step = np.array([0.5, 0.0, 0.01])
    for _ in range(30):
        truth = compose(truth, step)
        f.predict(step)
        z = truth + rng.multivariate_normal(np.zeros(3), r)
        f.update_point(PointFix(pose=z, cov=r))
    err = f.pose - truth
    assert abs(err[0]) < 0.1 and abs(err[1]) < 0.1 and abs(err[2]) < 0.03
    assert f.cov[0, 0] < 0.01 and f.cov[1, 1] < 0.01
    assert f.fixes_used == 30


def test_line_fix_only_corrects_the_cross_line_component():
    # Vehicle believed at (10, 1); the fix says it lies on the line y = 0 (direction along +x).
    f = PoseFilter(np.array([10.0, 1.0, 0.0]), np.diag([1.0, 1.0, 0.01]))
    before = f.pose
    f.update_line(LineFix(point=np.array([-50.0, 0.0]), angle=0.0, cross_var=0.01**2))
    after = f.pose
    assert abs(after[1]) < 0.02  # cross-line component pulled onto the line
    assert after[0] == pytest.approx(before[0], abs=1e-9)  # along-line untouched
    assert f.cov[1, 1] < 0.001 and f.cov[0, 0] == pytest.approx(1.0, rel=1e-6)


def test_diagonal_line_fix_moves_along_its_normal_only():
    f = PoseFilter(np.array([0.0, 2.0, 0.0]), np.diag([1.0, 1.0, 0.01]))
    f.update_line(LineFix(point=np.array([0.0, 0.0]), angle=math.pi / 4, cross_var=1e-6))
    moved = f.pose[:2] - np.array([0.0, 2.0])
    direction = np.array([math.cos(math.pi / 4), math.sin(math.pi / 4)])
    assert abs(moved @ direction) < 1e-3
    n = np.array([-direction[1], direction[0]])
    assert abs(f.pose[:2] @ n) < 1e-2


def test_late_fix_is_related_through_the_motion_since_capture():
    # Fix taken at truth (5, 0, 0); since then the vehicle moved 3 m forward.
    f = PoseFilter(np.array([8.0, 0.8, 0.0]), np.diag([1.0, 1.0, 0.05]), OdometryNoise())
    motion = np.array([3.0, 0.0, 0.0])
    f.update_point(PointFix(pose=np.array([5.0, 0.0, 0.0]), cov=np.diag([1e-4, 1e-4, 1e-5])), motion_since=motion)
    assert f.pose[0] == pytest.approx(8.0, abs=0.05) and abs(f.pose[1]) < 0.05


def test_world_from_local_correction():
    f = PoseFilter(np.array([10.0, 5.0, math.pi / 2]), np.eye(3) * 0.01)
    local_vehicle = np.array([2.0, 0.0, 0.0])
    wl = f.world_from_local(local_vehicle)
    assert np.allclose(compose(wl, local_vehicle), f.pose, atol=1e-9)


def test_bad_fixes_are_rejected_with_typed_errors():
    f = PoseFilter(np.zeros(3), np.eye(3))
    with pytest.raises(EstimatorError, match="positive definite"):
        f.update_point(PointFix(pose=np.zeros(3), cov=np.zeros((3, 3))))
    with pytest.raises(EstimatorError, match="finite"):
        f.update_point(PointFix(pose=np.array([np.nan, 0, 0]), cov=np.eye(3)))
    with pytest.raises(EstimatorError, match="cross variance"):
        f.update_line(LineFix(point=np.zeros(2), angle=0.0, cross_var=0.0))
    with pytest.raises(EstimatorError):
        PoseFilter(np.zeros(3), -np.eye(3))
    assert f.fixes_used == 0


def test_position_fix_moves_an_off_prior_toward_the_truth_and_the_gate_refuses_a_wrong_one():
    truth = np.array([10.0, 5.0])
    f = PoseFilter(np.array([10.6, 5.5, 0.0]), np.diag([0.3**2, 0.3**2, 0.01]))
    before = np.linalg.norm(f.pose[:2] - truth)
    f.update_position(truth, np.eye(2) * 0.1**2, gate=13.8)
    assert np.linalg.norm(f.pose[:2] - truth) < 0.3 * before
    assert f.fixes_used == 1
    # a fix 5 m off (a wrong landmark association) is refused and leaves the estimate alone
    pose, cov = f.pose, f.cov
    with pytest.raises(EstimatorError, match="refused"):
        f.update_position(truth + (5.0, 0.0), np.eye(2) * 0.1**2, gate=13.8)
    assert np.allclose(f.pose, pose) and np.allclose(f.cov, cov) and f.fixes_used == 1
    with pytest.raises(EstimatorError):
        f.update_position(truth, np.array([[1.0, 2.0], [2.0, 1.0]]))  # not positive definite
