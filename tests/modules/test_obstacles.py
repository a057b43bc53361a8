"""Obstacle detection on synthetic range images: a known box gives its polygon and height; the fast mode finds it on the path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scipy.ndimage import minimum_filter

from modules.perception.obstacles import ObstacleConfig, detect_obstacles, path_clear_distance, scan_points
from tests.modules._laser_synth import synthetic_scan


def test_known_box_gives_its_polygon_and_height() -> None:
    scan = synthetic_scan([(8.0, 9.0, -1.0, 0.5, 1.2)])
    obs = detect_obstacles(scan)
    assert len(obs) == 1
    o = obs[0]
    p = np.asarray(o.polygon)
    cell = ObstacleConfig().cell
    # the seen faces: front at x = 8 and the roof back to x = 9; both sides
    assert p[:, 0].min() == pytest.approx(8.0, abs=cell + 1e-6)
    assert p[:, 0].max() == pytest.approx(9.0, abs=cell + 1e-6)
    assert p[:, 1].min() == pytest.approx(-1.0, abs=cell + 1e-6)
    assert p[:, 1].max() == pytest.approx(0.5, abs=cell + 1e-6)
    assert o.height == pytest.approx(1.2, abs=0.05)
    assert o.distance == pytest.approx(math.hypot(8.0, 0.0), abs=0.5)


def test_flat_ground_and_low_kerb_are_not_obstacles() -> None:
    assert detect_obstacles(synthetic_scan([])) == []
    assert detect_obstacles(synthetic_scan([(6.0, 14.0, 3.0, 3.3, 0.15)])) == []  # a 15 cm kerb


def test_two_boxes_are_two_obstacles_nearest_first() -> None:
    obs = detect_obstacles(synthetic_scan([(12.0, 13.0, 2.0, 3.0, 0.8), (6.0, 6.5, -2.0, -1.5, 1.7)]))
    assert [round(o.height, 1) for o in obs] == [1.7, 0.8]
    assert obs[0].centroid[1] < 0 < obs[1].centroid[1]


def test_fast_mode_sees_only_the_corridor() -> None:
    scan = synthetic_scan([(10.0, 10.6, 2.5, 3.1, 1.7)])  # off to the left of a straight path
    straight = np.array([[0.0, 0.0], [20.0, 0.0]])
    assert path_clear_distance(scan, straight, 1.2) == math.inf
    veer = np.array([[0.0, 0.0], [5.0, 0.0], [10.0, 2.8], [20.0, 2.8]])  # the path turns into it
    d = path_clear_distance(scan, veer, 1.2)
    assert 10.0 < d < 12.5


def test_a_tree_one_ambiguity_interval_away_is_no_obstacle_in_the_near_field() -> None:
    # a tree 28.5 m ahead, 3-4.5 m to the right, behind a mailbox 16.5 m ahead that hides its foot (so the ground
    # gives no continuity to unwrap by): the tree's returns come back 20.48 m short, about 8 m ahead and 1 m to the
    # right, floating at the scanner's height in the corridor of a straight path (a generated suburb's stopped EDDIE
    # for good)
    far, mailbox = (28.5, 30.0, -4.5, -3.0, 6.0), (16.5, 16.9, -3.0, -1.7, 1.3)
    straight = np.array([[0.0, 0.0], [20.0, 0.0]])
    pts = scan_points(synthetic_scan([far, mailbox]))
    assert len(pts[(pts[:, 0] < 12.0) & (pts[:, 2] > 1.0)]) == 0
    assert path_clear_distance(synthetic_scan([far, mailbox]), straight, 1.5) == math.inf
    # a walker 8 m ahead on the path is still found, with the mailbox and the tree behind it
    d = path_clear_distance(synthetic_scan([far, mailbox, (8.0, 8.5, -0.3, 0.3, 1.8)]), straight, 1.5)
    assert 7.5 < d < 8.6


def _clear_distance_over_every_point(scan, path: np.ndarray, half_width: float, cfg: ObstacleConfig = ObstacleConfig(),  # noqa: ANN001
                                     min_points: int = 3) -> float:
    """The corridor test written plainly: every scan point against every segment, by norms (the reference)."""
    pts = scan_points(scan, cfg.max_horizontal)
    a, b = path[:-1], path[1:]
    e = b - a
    L = np.linalg.norm(e, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(L)])
    rel = pts[:, None, :2] - a[None]
    t = np.clip((rel * e[None]).sum(-1) / np.maximum(L * L, 1e-12)[None], 0.0, 1.0)
    d = np.linalg.norm(rel - t[..., None] * e[None], axis=-1)
    seg = np.argmin(d, axis=1)
    inside = d[np.arange(len(pts)), seg] <= half_width
    if not inside.any():
        return math.inf
    s = (cum[seg] + t[np.arange(len(pts)), seg] * L[seg])[inside]
    z, sig = pts[inside, 2], pts[inside, 3]
    order = np.argsort(s)
    s, z, sig = s[order], z[order], sig[order]
    bins = np.floor(s / 0.5).astype(np.int64)
    nb = int(bins.max()) + 1
    cnt = np.bincount(bins, minlength=nb)
    low = np.bincount(bins, weights=z.astype(np.float64), minlength=nb) / np.maximum(cnt, 1)
    low = minimum_filter(np.where(cnt > 0, low, np.inf), size=5, mode="nearest")
    hz = z - np.where(np.isfinite(low), low, 0.0)[bins]
    hot = (hz > cfg.min_height) & (hz > 3.0 * sig) & (z < cfg.max_height)
    return float(s[hot][min_points - 1]) if hot.sum() >= min_points else math.inf


def test_the_corridor_drops_no_point_the_full_test_keeps() -> None:
    """Only points in the path's box are tested against its segments: the distance is the plain test's, to the bit.

    Each scan has a box just inside the corridor's edge, on either side of a random path, where a box cut too
    tight would lose it.
    """
    rng = np.random.default_rng(3)
    found = 0
    for _ in range(40):
        steps = rng.normal([2.5, 0.0], [0.8, 1.5], size=(int(rng.integers(2, 8)), 2))
        path = np.cumsum(np.vstack([[0.0, 0.0], steps]), axis=0)
        half = float(rng.uniform(0.8, 2.5))
        k = int(rng.integers(1, len(path) - 1))
        e = path[k + 1] - path[k]
        n = np.array([-e[1], e[0]]) / max(float(np.hypot(*e)), 1e-9)
        cx, cy = path[k] + 0.5 * e + n * (half - 0.25) * rng.choice([-1.0, 1.0])
        boxes = [(cx - 0.2, cx + 0.2, cy - 0.2, cy + 0.2, 1.0)]
        x0, y0 = rng.uniform(3.0, 17.0), rng.uniform(-6.0, 6.0)
        boxes.append((x0, x0 + 1.0, y0, y0 + 1.0, 1.5))
        scan = synthetic_scan(boxes)
        want = _clear_distance_over_every_point(scan, path, half)
        assert path_clear_distance(scan, path, half) == want
        found += math.isfinite(want)
    assert found >= 10  # the corridors did meet boxes


def test_plan_goes_into_the_vehicle_frame_ahead_of_the_vehicle() -> None:
    from codger.obstacles.detector import plan_in_vehicle
    from modules.vocabulary import LocalPathPlan, PlanPose

    poses = tuple(PlanPose(x=10.0, y=float(y), yaw=math.pi / 2, speed=2.0) for y in range(0, 40, 2))
    plan = LocalPathPlan(seq=1, segment_id="s", poses=poses)
    p = plan_in_vehicle(plan, (10.0, 5.0, math.pi / 2), lookahead=10.0)  # vehicle at y = 5 heading north
    assert tuple(p[0]) == (0.0, 0.0)
    assert np.allclose(p[1:, 1], 0.0, atol=1e-9)  # straight ahead
    assert p[1, 0] == pytest.approx(1.0) and p[-1, 0] <= 12.0 + 1e-9
    short = plan_in_vehicle(LocalPathPlan(seq=2, segment_id="s", poses=poses[:5]), (10.0, 0.0, math.pi / 2), lookahead=15.0)
    assert short[-1, 0] == pytest.approx(15.0) and abs(short[-1, 1]) < 1e-9  # a short plan is carried on straight
