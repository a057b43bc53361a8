"""YARF: the robust spine fit rejects outliers, the trackers find stripes and report failures, real frames of schenley."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.road_following import CameraGeometry, Spine, Yarf, fit_spine_lsq, fit_spine_robust, track_white, track_yellow, yellow_mask
from modules.road_following.yarf_trackers import Window, shrink_and_grow


def test_robust_fit_recovers_a_known_parabola_with_outliers() -> None:
    rng = np.random.default_rng(7)
    truth = Spine(curvature=0.012, slope=-0.05, offset=1.6)
    x = rng.uniform(6.0, 24.0, 60)
    y = truth.lateral(x) + rng.normal(0.0, 0.04, x.size)
    bad = rng.choice(x.size, 18, replace=False)  # 30 % outliers: shadows, the edge of an added lane, grass
    y[bad] += rng.choice([-1.0, 1.0], bad.size) * rng.uniform(1.0, 3.5, bad.size)
    fit = fit_spine_robust(x, y)
    s = fit.spine
    assert abs(s.offset - truth.offset) < 0.1 and abs(s.slope - truth.slope) < 0.015 and abs(s.curvature - truth.curvature) < 0.0015
    assert set(np.flatnonzero(~fit.inliers)) == set(bad.tolist())
    # plain least squares is dragged off by the same outliers (the test can tell the two apart)
    ls = fit_spine_lsq(x, y)
    assert abs(ls.offset - truth.offset) + 10.0 * abs(ls.slope - truth.slope) > 0.2
    # and without outliers least squares is exact enough
    clean = np.setdiff1d(np.arange(x.size), bad)
    assert abs(fit_spine_lsq(x[clean], y[clean]).offset - truth.offset) < 0.1


def test_curvature_prior_holds_a_fit_with_near_points_only() -> None:
    x = np.array([6.0, 6.5, 7.0, 7.5, 8.0])
    y = 0.5 + 0.01 * x + np.array([0.03, -0.03, 0.02, -0.02, 0.0])
    free = fit_spine_lsq(x, y)
    held = fit_spine_lsq(x, y, curvature_prior=(0.0, 0.002))
    assert abs(held.curvature) < 0.002 < abs(free.curvature)


def _window(rows: int = 6, width: int = 41) -> tuple[np.ndarray, Window]:
    img = np.full((rows, width + 20, 3), (88, 88, 92), np.uint8)
    win = Window(rows=np.arange(rows), cols=np.full(rows, 10.0 + width // 2), half_px=width // 2, px_per_m=20.0)
    return img, win


def test_yellow_tracker_finds_the_line_and_reports_missing_and_too_large() -> None:
    img, win = _window()
    assert yellow_mask(np.array([[205, 160, 35], [77, 64, 16], [88, 88, 92], [85, 135, 200]], np.uint8)).tolist() == [True, True, False, False]
    img[:, 36:40] = (205, 160, 35)  # a 0.2 m line, 6 px right of the window centre (column 30)
    img[2, 15] = (205, 160, 35)  # a lone speck: shrink-and-grow removes it
    res = track_yellow(img, win, 0.2)
    assert res.status == "found" and res.uv is not None and abs(res.uv[0] - 37.5) < 0.6
    assert not shrink_and_grow(np.eye(6, dtype=bool)).any()
    empty, win = _window()
    assert track_yellow(empty, win, 0.2).status == "missing"
    grass, win = _window()
    grass[:] = (120, 140, 40)  # yellow-green grass fills the window
    assert track_yellow(grass, win, 0.2).status == "too_large"


def test_white_tracker_finds_a_bar_not_a_shadow_edge() -> None:
    img, win = _window()
    img[:, 24:27] = (222, 222, 214)  # a 0.12 m stripe (3 px) at columns 24–26
    res, model = track_white(img, win, 0.12)
    assert res.status == "found" and res.uv is not None and abs(res.uv[0] - 25.0) < 0.6
    assert model.background is not None
    edge, win = _window()
    edge[:, :30] = (33, 35, 43)  # a tree shadow's edge across the window: no bar there
    assert track_white(edge, win, 0.12)[0].status == "missing"
    clipped, win = _window()
    clipped[:, 10:13] = (222, 222, 214)  # the stripe at the window's very edge
    assert track_white(clipped, win, 0.12)[0].status in ("clipped", "missing")
    # the sun goes in on an empty window: the tracker says the light changed, not that the stripe is gone
    dark, win = _window()
    dark[:] = (30, 30, 33)
    assert track_white(dark, win, 0.12, model)[0].status == "illumination_shift"


@pytest.fixture(scope="module")
def schenley():
    from tests.modules._road_frames import route_frames

    return route_frames("schenley")


def test_yarf_tracks_the_marked_road_through_the_bend_and_the_added_lane(schenley) -> None:
    from sidewalk.roadfollow_eval import DrivePose, centre_at_origin, plan_drive, to_vehicle
    from modules.road_following import VehicleMotion

    rng = np.random.default_rng(4)
    poses = plan_drive(schenley.legs[:1], 400, rng, step_m=3.6, lane_offset_m=-1.75)
    poses = [p for p in poses if p.x > 20.0]  # the bend, the passing zone, the broken edge, the added lane
    yarf: Yarf | None = None
    prev: DrivePose | None = None
    errs = []
    statuses: set[str] = set()
    for fr, cap in schenley.frames(poses, rng):
        if yarf is None:
            yarf = Yarf(CameraGeometry.from_capture(cap), prior=Spine(offset=1.75))
        motion = None
        if prev is not None:
            d = to_vehicle(np.array([[fr.pose.x, fr.pose.y]]), prev)[0]
            motion = VehicleMotion(dx=float(d[0]), dy=float(d[1]), dyaw=fr.pose.yaw - prev.yaw)
        prev = fr.pose
        obs = yarf.observe(fr.image, stamp=fr.pose.stamp, motion=motion)
        truth = centre_at_origin(to_vehicle(fr.centre_world, fr.pose))
        assert truth is not None
        errs.append(abs(obs.lateral_offset_m - truth[0]))
        assert obs.found, f"lost at x = {fr.pose.x:.0f} m"
        assert {r.kind for r in obs.features} == {"yellow", "white"}
        statuses.update(r.status for r in obs.features)
    assert len(errs) > 20 and np.median(errs) < 0.15 and max(errs) < 0.5
    assert {"found", "missing"} <= statuses  # broken lines and shadows leave windows empty; the fit carries on
