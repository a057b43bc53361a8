"""Obstacle detection on synthetic range images: a known box gives its polygon and height; the fast mode finds it on the path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.perception.obstacles import ObstacleConfig, detect_obstacles, path_clear_distance
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
