"""Frame tree and pose history: interpolation, extrapolation errors, static frames, composition."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blackboard import FutureExtrapolationError, InvalidTokenError, PastExtrapolationError, Pose2D, UnknownFrameError
from blackboard.frames import FrameTree
from wire.se2 import transform_points


def approx_pose(T, x, y, yaw, tol=1e-9):
    assert T[0] == pytest.approx(x, abs=tol)
    assert T[1] == pytest.approx(y, abs=tol)
    assert math.atan2(math.sin(T[2] - yaw), math.cos(T[2] - yaw)) == pytest.approx(0.0, abs=tol)


def test_interpolates_translation_linearly_between_samples():
    ft = FrameTree()
    ft.add_pose("local", "vehicle", Pose2D(x=0, y=0, yaw=0), 0.0)
    ft.add_pose("local", "vehicle", Pose2D(x=10, y=-4, yaw=0), 2.0)
    approx_pose(ft.lookup("local", 0.5, "vehicle", 0.5), 2.5, -1.0, 0.0)
    assert ft.lookup_pose("local", "vehicle", 1.0) == Pose2D(x=5.0, y=-2.0, yaw=0.0)


def test_yaw_interpolates_along_the_shorter_arc():
    ft = FrameTree()
    ft.add_pose("local", "vehicle", Pose2D(x=0, y=0, yaw=math.pi - 0.1), 0.0)
    ft.add_pose("local", "vehicle", Pose2D(x=0, y=0, yaw=-math.pi + 0.1), 1.0)
    p = ft.lookup_pose("local", "vehicle", 0.5)
    assert abs(abs(p.yaw) - math.pi) < 1e-9  # through ±pi, not through 0


def test_past_and_future_extrapolation_are_distinct_errors():
    ft = FrameTree()
    ft.add_pose("local", "vehicle", Pose2D(x=0, y=0, yaw=0), 1.0)
    ft.add_pose("local", "vehicle", Pose2D(x=1, y=0, yaw=0), 2.0)
    with pytest.raises(PastExtrapolationError):
        ft.lookup_pose("local", "vehicle", 0.5)
    with pytest.raises(FutureExtrapolationError):
        ft.lookup_pose("local", "vehicle", 2.5)
    assert issubclass(PastExtrapolationError, Exception) and not issubclass(PastExtrapolationError, FutureExtrapolationError)


def test_bounded_history_forgets_old_poses():
    ft = FrameTree(history=5.0)
    for t in range(20):
        ft.add_pose("local", "vehicle", Pose2D(x=float(t), y=0, yaw=0), float(t))
    approx_pose(ft.lookup("local", 15.0, "vehicle", 15.0), 15.0, 0.0, 0.0)
    with pytest.raises(PastExtrapolationError):
        ft.lookup("local", 10.0, "vehicle", 10.0)


def test_max_samples_bounds_history():
    ft = FrameTree(history=1e9, max_samples=10)
    for t in range(30):
        ft.add_pose("local", "vehicle", Pose2D(x=float(t)), float(t))
    with pytest.raises(PastExtrapolationError):
        ft.lookup_pose("local", "vehicle", 5.0)
    assert ft.lookup_pose("local", "vehicle", 25.0).x == pytest.approx(25.0)


def test_out_of_order_samples_are_sorted():
    ft = FrameTree()
    ft.add_pose("local", "vehicle", Pose2D(x=2), 2.0)
    ft.add_pose("local", "vehicle", Pose2D(x=0), 0.0)
    ft.add_pose("local", "vehicle", Pose2D(x=1.5), 1.0)
    assert ft.lookup_pose("local", "vehicle", 1.0).x == pytest.approx(1.5)
    assert ft.lookup_pose("local", "vehicle", 0.5).x == pytest.approx(0.75)


def test_static_frames_answer_for_any_time():
    ft = FrameTree()
    ft.set_static("vehicle", "camera", Pose2D(x=1.5, y=0.2, yaw=0.1))
    for t in (-1e6, 0.0, 123.4, 1e9):
        approx_pose(ft.lookup("vehicle", t, "camera", t), 1.5, 0.2, 0.1)
    with pytest.raises(InvalidTokenError):
        ft.add_pose("vehicle", "camera", Pose2D(), 1.0)


def test_world_local_correction_composes_with_local_vehicle_pose():
    ft = FrameTree()
    # correction: local origin sits at (100, 50) in world, rotated 90°
    ft.add_pose("world", "local", Pose2D(x=100, y=50, yaw=math.pi / 2), 0.0, hold=math.inf)
    ft.add_pose("local", "vehicle", Pose2D(x=0, y=0, yaw=0), 0.0)
    ft.add_pose("local", "vehicle", Pose2D(x=10, y=0, yaw=0), 10.0)
    ft.set_static("vehicle", "camera", Pose2D(x=1, y=0, yaw=0))
    # vehicle at t=5 is at local (5,0) → world (100, 55), heading 90°
    approx_pose(ft.lookup("world", 5.0, "vehicle", 5.0), 100.0, 55.0, math.pi / 2)
    # a point 2 m ahead of the camera at t=5: local (8,0) → world (100, 58)
    out = ft.transform_points(np.array([[2.0, 0.0]]), "camera", 5.0, "world", None)
    np.testing.assert_allclose(out, [[100.0, 58.0]], atol=1e-9)
    # same point relative to the vehicle at t=10 (vehicle moved 5 m on): (3, 0) ahead
    out = ft.transform_points(np.array([[2.0, 0.0]]), "camera", 5.0, "vehicle", 10.0)
    np.testing.assert_allclose(out, [[-2.0, 0.0]], atol=1e-9)  # vehicle@10 at local 10; point at local 8


def test_vehicle_to_vehicle_across_time_uses_odometry_not_corrections():
    ft = FrameTree()
    ft.add_pose("world", "local", Pose2D(x=0, y=0, yaw=0), 0.0)
    ft.add_pose("world", "local", Pose2D(x=50, y=0, yaw=1.0), 10.0)  # a large correction jump
    ft.add_pose("local", "vehicle", Pose2D(x=0, y=0, yaw=0), 0.0)
    ft.add_pose("local", "vehicle", Pose2D(x=10, y=0, yaw=0), 10.0)
    out = ft.transform_points(np.array([[0.0, 0.0]]), "vehicle", 0.0, "vehicle", 10.0)
    np.testing.assert_allclose(out, [[-10.0, 0.0]], atol=1e-9)


def test_correction_hold_and_unknown_frames():
    ft = FrameTree()
    ft.add_pose("world", "local", Pose2D(x=1), 0.0, hold=5.0)
    assert ft.lookup_pose("world", "local", 4.0).x == 1.0
    with pytest.raises(FutureExtrapolationError):
        ft.lookup_pose("world", "local", 6.0)
    with pytest.raises(UnknownFrameError):
        ft.lookup("world", 0.0, "nowhere", 0.0)
    ft.set_static("mast", "lidar", Pose2D())
    with pytest.raises(UnknownFrameError):
        ft.lookup("world", 0.0, "lidar", 0.0)


def test_tree_rejects_reparenting_and_cycles():
    ft = FrameTree()
    ft.set_static("a", "b", Pose2D())
    with pytest.raises(InvalidTokenError):
        ft.set_static("c", "b", Pose2D())
    with pytest.raises(InvalidTokenError):
        ft.set_static("b", "a", Pose2D())


def test_inverse_pair_round_trips_points():
    rng = np.random.default_rng(7)
    ft = FrameTree()
    ft.add_pose("local", "vehicle", Pose2D(x=3, y=-2, yaw=0.7), 1.0)
    pts = rng.normal(size=(100, 2))
    there = ft.transform_points(pts, "vehicle", 1.0, "local", 1.0)
    back = ft.transform_points(there, "local", 1.0, "vehicle", 1.0)
    np.testing.assert_allclose(back, pts, atol=1e-12)
    np.testing.assert_allclose(transform_points((0.0, 0.0, 0.0), pts), pts)


def test_newest_lookup_uses_the_freshest_answerable_time():
    ft = FrameTree()
    ft.add_pose("world", "local", Pose2D(x=100), 5.0, hold=math.inf)  # a correction, valid until the next
    ft.add_pose("local", "vehicle", Pose2D(x=1), 9.0)
    ft.add_pose("local", "vehicle", Pose2D(x=2), 10.0)
    assert ft.lookup_pose("world", "vehicle", None).x == pytest.approx(102.0)
    assert ft.lookup_pose("world", "local", None).x == pytest.approx(100.0)
    assert ft.latest_time("vehicle") == pytest.approx(10.0)
