"""The one SE(2) kernel: its inverse pairs undo each other, its forms agree, its wrap brings every angle into [-pi, pi)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wire.se2 import (
    Pose2D, PoseFields, between, between_tuple, compose, compose_tuple, interpolate_tuple, inverse, inverse_transform_points,
    inverse_tuple, transform_points, wrap_angle,
)


def _poses(n: int, seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-500, 500, n), rng.uniform(-500, 500, n), rng.uniform(-3 * math.pi, 3 * math.pi, n)])


def test_wrap_brings_every_angle_into_range_and_moves_one_there_by_at_most_half_an_ulp_of_pi() -> None:
    inside = np.random.default_rng(1).uniform(-math.pi, math.pi, 1000)
    assert max(abs(wrap_angle(float(a)) - float(a)) for a in inside) <= math.ulp(math.pi) / 2
    assert wrap_angle(math.pi) == -math.pi and wrap_angle(-math.pi) == -math.pi
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2, abs=1e-15)
    outside = np.random.default_rng(2).uniform(-50.0, 50.0, 1000)
    for a in outside:
        w = wrap_angle(float(a))
        assert -math.pi <= w < math.pi
        assert math.sin(w) == pytest.approx(math.sin(a), abs=1e-12) and math.cos(w) == pytest.approx(math.cos(a), abs=1e-12)
    # arrays elementwise, by the same rule
    both = np.concatenate([inside, outside])
    np.testing.assert_array_equal(wrap_angle(both), [wrap_angle(float(a)) for a in both])


def test_compose_and_between_undo_each_other_and_inverse_is_compose_with_identity() -> None:
    P = _poses(200)
    for a, b in zip(P[:100], P[100:]):
        ab = compose_tuple(a, b)
        np.testing.assert_allclose(between_tuple(a, ab)[:2], b[:2], atol=1e-9)
        assert wrap_angle(between_tuple(a, ab)[2] - b[2]) == pytest.approx(0.0, abs=1e-12)
        e = compose_tuple(a, inverse_tuple(a))
        np.testing.assert_allclose(e, (0.0, 0.0, 0.0), atol=1e-9)
        # the array forms are the tuple forms
        np.testing.assert_array_equal(compose(a, b), ab)
        np.testing.assert_array_equal(between(a, b), between_tuple(a, b))
        np.testing.assert_array_equal(inverse(a), inverse_tuple(a))


def test_transform_points_pair_undo_each_other_and_agree_with_compose() -> None:
    rng = np.random.default_rng(3)
    pts = rng.uniform(-30, 30, (50, 2))
    for pose in _poses(20):
        there = transform_points(pose, pts)
        np.testing.assert_allclose(inverse_transform_points(pose, there), pts, atol=1e-9)
        want = np.array([compose_tuple(pose, (x, y, 0.0))[:2] for x, y in pts])
        np.testing.assert_allclose(there, want, atol=1e-9)


def test_interpolate_runs_along_the_shorter_arc() -> None:
    a, b = (0.0, 0.0, math.pi - 0.1), (10.0, -4.0, -math.pi + 0.1)
    x, y, yaw = interpolate_tuple(a, b, 0.5)
    assert (x, y) == (5.0, -2.0)
    assert abs(wrap_angle(yaw - math.pi)) < 1e-12  # through pi, not through 0
    assert interpolate_tuple(a, b, 0.0) == pytest.approx(a, abs=1e-15)


def test_pose2d_methods_are_the_kernel() -> None:
    P = _poses(40, seed=11)
    for a, b in zip(P[:20], P[20:]):
        pa, pb = Pose2D.from_array(a), Pose2D.from_array(b)
        assert pa.compose(pb).as_tuple() == compose_tuple(pa.as_tuple(), pb.as_tuple())
        assert pa.between(pb).as_tuple() == between_tuple(pa.as_tuple(), pb.as_tuple())
        assert pa.inverse().as_tuple() == inverse_tuple(pa.as_tuple())
        q = pa.compose(pa.between(pb))
        assert (q.x, q.y) == pytest.approx((pb.x, pb.y), abs=1e-9)


def test_a_pose_message_converts_through_the_named_pair() -> None:
    from pydantic import BaseModel, ConfigDict

    class Fix(PoseFields, BaseModel):
        model_config = ConfigDict(frozen=True)
        stamp: float
        x: float
        y: float
        yaw: float

    p = Pose2D(3.0, -2.0, 0.5)
    m = Fix.from_pose2d(p, stamp=4.0)
    assert m == Fix(stamp=4.0, x=3.0, y=-2.0, yaw=0.5) and m.to_pose2d() == p
    assert Fix.from_pose2d(np.array([3.0, -2.0, 0.5]), stamp=4.0) == m


def test_no_source_file_wraps_an_angle_but_the_kernel() -> None:
    """`atan2(sin a, cos a)`, `remainder(a, 2pi)` and `(a + pi) % 2pi - pi` written out anywhere else is a second wrap."""
    import re
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    wraps = re.compile(r"atan2\(\s*(np\.|math\.)?sin\(|remainder\([^\n]*2(\.0)?\s*\*\s*(np|math)\.pi|%\s*\(?\s*2(\.0)?\s*\*\s*(np|math)\.pi")
    # the ray caster and the cross-country search are compiled by numba, which cannot call back into Python
    allowed = {"wire/se2.py", "vehicle_sim/solid_cast.py", "vehicle_sim/ray_cast.py", "modules/terrain/cross_country_planner.py",
               "modules/terrain/resolution_hierarchy.py"}
    found = sorted(f"{p.relative_to(repo).as_posix()}:{i}" for pkg in ("wire", "blackboard", "modules", "vehicle_sim", "eddie", "sidewalk", "bench")
                   for p in (repo / pkg).rglob("*.py") if p.relative_to(repo).as_posix() not in allowed
                   for i, line in enumerate(p.read_text().splitlines(), 1) if wraps.search(line))
    assert found == []
