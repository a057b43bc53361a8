"""YARF without a prior: the vanishing-point Hough, the bootstrap spine, lock-on."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from modules.road_following import CameraGeometry, LaneModel, Spine, VehicleMotion, Yarf
from modules.road_following.vanishing_point import VanishingConfig, vanishing_lines
from modules.road_following.yarf_bootstrap import bootstrap_spine
from sidewalk.roadfollow_eval import FrameScore, lock_on

pytestmark = pytest.mark.timeout(120)  # quiet run ~14 s (simulator frames and the Hough on each; measured under load)


def test_the_hough_finds_the_vanishing_point_of_painted_lines_and_ignores_a_shadow_edge() -> None:
    h, w, horizon, vp = 120, 160, 40.0, 95.0
    img = np.full((h, w), 90, np.uint8)
    for bottom in (-20.0, 60.0, 150.0):  # three stripes meeting at (vp, horizon)
        cv2.line(img, (int(vp + (bottom - vp) * 0.15), int(horizon + 12)), (int(bottom), h - 1), 230, 2, cv2.LINE_AA)
    img[100:108, :] = (img[100:108, :] * 0.45).astype(np.uint8)  # a tree's shadow across the road: edges along the rows
    bands = vanishing_lines(img, horizon, VanishingConfig())
    assert all(b.lines for b in bands)
    # a short band's lines extrapolated to the horizon swing by a few pixels (why the bootstrap reads their ends instead)
    assert abs(np.median([b.vp for b in bands]) - vp) <= 4.0 and all(abs(b.vp - vp) <= 10.0 for b in bands), [b.vp for b in bands]
    assert all(math.radians(12.0) <= t <= math.radians(168.0) for b in bands for _, t, _ in b.lines)  # no line along the shadow
    bottom_cols = sorted(b.column_at(t, h - 1, horizon) for b in bands[-1:] for _, t, _ in b.lines)
    for want in (-20.0, 60.0, 150.0):
        if 0 <= want < w:
            assert min(abs(c - want) for c in bottom_cols) < 4.0


def test_lock_on_is_the_first_frame_near_the_truth_that_is_then_held() -> None:
    ok, near_miss, lost = FrameScore(True, 0.05, 0.5, 1, 1), FrameScore(True, 0.6, 4.0, 1, 1), FrameScore(False, math.nan, math.nan, 1, 1)
    assert lock_on([lost, near_miss, ok, near_miss, ok]).frame == 3  # a near miss afterwards is tracking noise, not a loss
    assert lock_on([ok, lost, ok, ok]).frame == 3
    assert lock_on([ok, ok, lost]).frame is None


@pytest.fixture(scope="module")
def schenley():
    from tests.modules._road_frames import route_frames

    return route_frames("schenley")


def test_yarf_locks_on_from_off_its_lane_with_no_prior(schenley) -> None:
    from sidewalk.roadfollow_eval import DrivePose, centre_at_origin, score_frame, to_vehicle

    feats = tuple((f.kind, f.offset_m) for f in LaneModel().features)
    rng = np.random.default_rng(11)
    for off, dpsi in ((1.4, -8.0), (-1.8, 6.0)):  # metres off the right lane's centre (+ left), degrees off the road
        poses = [DrivePose(leg=0, x=20.0 + 3.0 * k, y=-1.75 + off, yaw=math.radians(dpsi), stamp=k * 0.7) for k in range(6)]
        yarf, prev, scores = None, None, []
        for fr, cap in schenley.frames(poses, rng):
            cam = CameraGeometry.from_capture(cap)
            truth = centre_at_origin(to_vehicle(fr.centre_world, fr.pose))
            if yarf is None:
                first = bootstrap_spine(fr.image, cam, feats)
                assert first.spine is not None and abs(first.spine.offset - truth[0]) < 0.6
                yarf = Yarf(cam, prior=None)
            motion = None
            if prev is not None:  # the odometry: the vehicle moves along the road while heading off it
                d = to_vehicle(np.array([[fr.pose.x, fr.pose.y]]), prev)[0]
                motion = VehicleMotion(dx=float(d[0]), dy=float(d[1]))
            prev = fr.pose
            scores.append(score_frame(yarf.observe(fr.image, stamp=fr.pose.stamp, motion=motion), to_vehicle(fr.centre_world, fr.pose), 0.0))
        got = lock_on(scores)
        assert got.frame is not None and got.frame <= 5, (off, dpsi, scores)
    # a prior in the wrong lane (the seed's bootstrap told wrong) is not the road: YARF keeps looking there and does not lock
    poses = [DrivePose(leg=0, x=20.0 + 3.0 * k, y=-1.75, yaw=0.0, stamp=k * 0.7) for k in range(4)]
    yarf, scores = None, []
    for fr, cap in schenley.frames(poses, rng):
        yarf = yarf or Yarf(CameraGeometry.from_capture(cap), prior=Spine(offset=1.75 + 3.55))
        scores.append(score_frame(yarf.observe(fr.image, stamp=fr.pose.stamp, motion=VehicleMotion(dx=3.0)), to_vehicle(fr.centre_world, fr.pose), 0.0))
    assert lock_on(scores).frame is None
