"""Landmarks and map building on synthetic range images: a post is found, matched and fixes the pose; a landmark
seen then missed loses confidence; a moving object never enters the built map."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.perception.landmarks import (MapLandmark, landmark_fix, landmark_observations, match_landmarks,
                                          observation_covariance)
from modules.perception.object_tracker import ObjectTracker, WorldObservation
from modules.perception.obstacles import detect_obstacles
from tests.modules._laser_synth import synthetic_scan


def _world_obs(scan_boxes, pose):
    """Detect landmarks in a synthetic scan seen from `pose` and put them in the world frame."""
    out = []
    c, s = math.cos(pose[2]), math.sin(pose[2])
    R = np.array([[c, -s], [s, c]])
    for o in landmark_observations(detect_obstacles(synthetic_scan(scan_boxes))):
        w = np.array(pose[:2]) + R @ np.array([o.x, o.y])
        cw = R @ np.asarray(o.cov) @ R.T
        out.append(WorldObservation(x=float(w[0]), y=float(w[1]), cov=((cw[0, 0], cw[0, 1]), (cw[1, 0], cw[1, 1])),
                                    size=o.size, height=o.height))
    return out


def _box_at(x, y, half=0.2, h=1.2):
    return (x - half, x + half, y - half, y + half, h)


def test_covariance_grows_with_distance() -> None:
    near = np.linalg.det(observation_covariance(4.0, 0.0))
    far = np.linalg.det(observation_covariance(16.0, 0.0))
    assert far > 4 * near


def test_post_matches_the_map_and_fixes_an_offset_pose() -> None:
    # truth: vehicle at (0, 0, 0), posts at (9, 2) and (12, -3); the prior pose is 0.8 m off in y
    obs = landmark_observations(detect_obstacles(synthetic_scan([_box_at(9.0, 2.0), _box_at(12.0, -3.0)])))
    assert len(obs) == 2
    lms = [MapLandmark(id="a", x=109.0, y=52.0), MapLandmark(id="b", x=112.0, y=47.0), MapLandmark(id="far", x=130.0, y=60.0)]
    prior = (100.0, 50.8, 0.0)
    m = match_landmarks(obs, lms, prior, pose_cov=np.eye(2) * 1.0)
    assert sorted(x.landmark_id for x in m) == ["a", "b"]
    fix = landmark_fix(m)
    assert fix is not None
    assert fix.dy == pytest.approx(-0.8, abs=0.2)
    assert fix.dx == pytest.approx(0.0, abs=0.3)
    # outside the gate nothing matches: a map 6 m off
    assert match_landmarks(obs, [MapLandmark(id="a", x=109.0, y=58.0)], prior) == []


def test_landmark_seen_then_missed_loses_confidence() -> None:
    tr = ObjectTracker()
    pose = (0.0, 0.0, 0.0)
    for _ in range(4):
        tr.update(pose, _world_obs([_box_at(10.0, 1.0)], pose))
    (seen,) = tr.objects()
    assert seen.hits == 4 and seen.confidence > 0.8
    assert len(tr.mapped()) == 1
    tr.update(pose, _world_obs([], pose))  # it should appear, it is gone
    (missed,) = tr.objects()
    assert missed.confidence < seen.confidence and missed.misses == 1
    for _ in range(4):
        tr.update(pose, [])
    assert tr.objects() == [] and tr.mapped() == []
    assert tr.dropped_spurious == 1


def test_moving_object_never_enters_the_map() -> None:
    tr = ObjectTracker()
    pose = (0.0, 0.0, 0.0)
    for k in range(10):  # a post stays at (12, -2); a walker crosses at y = -3 … +3 at 12 m
        y = -3.0 + 0.6 * k
        tr.update(pose, _world_obs([_box_at(12.0, -2.0 if abs(y + 2.0) > 1.5 else -6.0), _box_at(9.0, y, 0.25, 1.7)], pose))
    mapped = tr.mapped()
    assert all(abs(o.x - 9.0) > 1.0 for o in mapped), mapped
    assert any(o.moving for o in tr.objects())
    assert any(abs(o.x - 12.0) < 0.5 for o in mapped)
    # maximum-likelihood position of the post: close, with a covariance smaller than one sighting's
    post = min(mapped, key=lambda o: abs(o.x - 12.0) + abs(o.y + 2.0))
    assert np.linalg.det(np.asarray(post.cov)) < np.linalg.det(observation_covariance(12.0, -2.0))
