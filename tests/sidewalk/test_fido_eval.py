"""`sidewalk perception eval --fido`: its figures from known inputs, and the command end to end (strict JSON, no NaN)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from modules.fido import PlanarMotion
from sidewalk.cli import app
from sidewalk.fido_eval import (
    GROUND_KINDS,
    ClutterCounts,
    DepthErrors,
    MotionLeg,
    approach_leg,
    ground_grid,
    json_ready,
    relative_motion,
    segment_leg,
    straight_leg,
)
from tests.vehicle_sim.test_sensors_stereo import MARK, STEREO
from tests.vehicle_sim.test_scene import synthetic_world
from vehicle_sim.scene import Scene
from vehicle_sim.sensors import capture
from vehicle_sim.worldfile import KINDS

REPO = Path(__file__).resolve().parents[2]


def test_depth_errors_fall_in_bands_of_true_depth() -> None:
    d = DepthErrors()
    d.add(np.array([2.1, 7.0, 13.0, 30.0, 5.0, 60.0, 3.0]), np.array([2.0, 7.5, 12.0, 25.0, np.nan, 55.0, np.inf]))
    out = d.as_dict()
    assert out["0-5m"] == {"p50": pytest.approx(0.1), "p95": pytest.approx(0.1), "n": 1}
    assert out["5-10m"]["p50"] == pytest.approx(0.5) and out["10-20m"]["p50"] == pytest.approx(1.0)
    assert out["20-40m"]["p50"] == pytest.approx(5.0)
    assert out["no_truth"] == 2 and out["beyond"] == 1


def test_a_motion_leg_integrates_the_estimates_and_stands_in_the_odometry_for_failures() -> None:
    leg = MotionLeg()
    poses = [np.array([10.0 + k, 5.0, 0.0]) for k in range(11)]
    leg.add(poses[0], None, None, None)
    for k in range(1, 11):
        truth = relative_motion(poses[k - 1], poses[k])
        est = None if k == 4 else PlanarMotion(1.01, 0.0, 0.0)  # 1 % long; one step failed
        leg.add(poses[k], truth, est, PlanarMotion(1.05, 0.0, 0.0))
    out = leg.as_dict()
    assert out["distance_m"] == pytest.approx(10.0)
    assert out["end_error_m"] == pytest.approx(9 * 0.01 + 0.05)
    assert out["failures"] == 1 and out["steps"] == 10
    assert out["distance_error_pct"] == pytest.approx(1.4)
    assert np.median(leg.step_err) == pytest.approx(0.01)


def test_relative_motion_is_the_previous_frames_view() -> None:
    m = relative_motion(np.array([1.0, 2.0, math.pi / 2]), np.array([1.0, 3.0, math.pi / 2 + 0.1]))
    assert (m.dx, m.dy, m.dyaw) == pytest.approx((1.0, 0.0, 0.1))


def test_legs_follow_the_route_and_stop_short_of_the_target() -> None:
    rng = np.random.default_rng(0)
    segs = [(np.array([0.0, 0.0]), np.array([60.0, 0.0])), (np.array([60.0, 0.0]), np.array([60.0, 8.0]))]
    s = straight_leg(segs, 50.0, 1.0, 0.0, 2.0, rng)
    assert len(s.poses) == 51 and s.kind == "straight"
    assert np.allclose(s.poses[:, 1], -0.75) and s.poses[0, 0] == pytest.approx(1.0) and s.poses[-1, 0] == pytest.approx(51.0)
    assert np.allclose(np.diff(s.stamps), 2.0)
    assert straight_leg(segs, 70.0, 1.0, 0.0, 2.0, rng) is None
    a = approach_leg(segs, (40.0, 0.5), 10, 1.0, 0.0, 2.0, rng)
    assert len(a.poses) == 11 and a.poses[-1, 0] == pytest.approx(37.0) and abs(a.poses[0, 2]) < math.radians(5)
    r = segment_leg(segs, 10, 1.0, 0.0, 2.0, rng)
    assert 2 <= len(r.poses) <= 11 and np.all(np.abs(np.diff(r.poses[:, :2], axis=0)).sum(axis=1) == pytest.approx(1.0))


def test_clutter_counts_add_flags_and_leave_empty_shares_null() -> None:
    c = ClutterCounts()
    assert c.as_dict()["on_leaves_share"] is None
    c.add(np.array([True, False, True, False]), np.array([False, False, True, False]))
    c.add(np.zeros(0, bool), np.zeros(0, bool))
    assert c.as_dict() == {"features": 4, "on_leaves": 2, "at_shadow_edges": 1, "on_leaves_share": 0.5, "at_shadow_edges_share": 0.25}


@pytest.mark.timeout(30)  # quiet run ~1 s
def test_the_ground_grid_keeps_ground_pixels_within_reach() -> None:
    """A red square on the ground 8–9 m ahead: its grid pixels come in with a reach of 9.5 m, not with 7.5 m."""
    cap = capture(Scene(synthetic_world(extra=(MARK,)), seed=7), (0.0, 0.0, 0.0), 2.0, STEREO, vehicle="terregator",
                  rng=np.random.default_rng(1))
    labels = cap.stereo_labels[4::8, 4::8]
    mark = {(int(j) * 8 + 4, int(i) * 8 + 4) for i, j in zip(*np.nonzero(labels == KINDS.index("intersection")))}
    assert len(mark) >= 2
    near, far, all_ = (set(map(tuple, ground_grid(cap, r).tolist())) for r in (7.5, 9.5, 40.0))
    assert mark <= far and not mark & near and near < far <= all_
    for u, v in all_:
        assert u % 8 == 4 and v % 8 == 4 and KINDS[cap.stereo_labels[v, u]] in GROUND_KINDS


def test_json_ready_turns_non_finite_figures_into_null() -> None:
    out = json_ready({"a": float("nan"), "b": [np.float32(1.5), np.inf], "c": {"d": np.int64(3)}})
    assert json.dumps(out, allow_nan=False) == '{"a": null, "b": [1.5, null], "c": {"d": 3}}'


def test_bad_flags_are_named() -> None:
    runner = CliRunner()
    r = runner.invoke(app, ["perception", "eval", "--fido", "--laser"])
    assert r.exit_code == 2 and "--laser and --fido" in r.output
    r = runner.invoke(app, ["perception", "eval", "--fido", "--straight-leg", "-3"])
    assert r.exit_code == 2 and "--straight-leg" in r.output


@pytest.mark.timeout(600)  # quiet run ~7 s (170–280 s measured at a load of 25–40 on 2 cores)
def test_eval_fido_prints_every_figure_as_strict_json() -> None:
    """Two steps towards an actor and a 2 m straight leg on campus; a straight leg too long for any route piece is refused."""
    def no_nan(tok):
        raise AssertionError(f"non-JSON constant {tok} in the output")

    p = subprocess.run([sys.executable, "-m", "sidewalk", "perception", "eval", "--fido", "--world", "campus", "--frames", "2",
                        "--straight-leg", "2", "--seed", "2", "--json"], cwd=REPO, capture_output=True, text=True, timeout=540)
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout, parse_constant=no_nan)
    assert out["actors"] == "campus-eval" and out["steps"] == 6 and out["legs"] == 2
    assert set(out["obstacles"]) == {"fido", "sgbm", "laser"} and set(out["motion"]) == {"fido", "sgbm_lk", "odometry"}
    assert set(out["false_detection_surfaces"]) == {"sgbm", "laser"}
    assert sum(out["false_detection_surfaces"]["sgbm"].values()) == round(out["obstacles"]["sgbm"]["obstacle_detections"]
                                                                         * out["obstacles"]["sgbm"]["false_positive_rate"])
    for method in ("fido", "sgbm"):
        near = out["depth_error_m"][method]["0-5m"]
        assert near["n"] > 0 and near["p50"] < 0.2
    assert out["obstacles"]["laser"]["obstacle_visible"] > 0
    straight = out["straight_leg"]
    assert straight["fido"]["distance_m"] == pytest.approx(2.0, abs=0.01) and straight["fido"]["end_error_pct"] < 5.0
    assert out["ms_per_step"]["fido"]["p50"] > 0 and out["ms_per_step"]["fido"]["cpu_p50"] > 0
    assert out["stereo"] == {"size_px": 512, "hfov_deg": 60.0, "baseline_m": 0.5}
    for k in ("all_features", "ground_pixels"):
        clutter = out["fido_ground_clutter"][k]
        assert clutter["features"] > 0 and 0 <= clutter["on_leaves"] <= clutter["features"]
    p = subprocess.run([sys.executable, "-m", "sidewalk", "perception", "eval", "--fido", "--world", "campus", "--frames", "1",
                        "--straight-leg", "500", "--json"], cwd=REPO, capture_output=True, text=True, timeout=90)
    assert p.returncode == 2 and "--straight-leg 500" in p.stderr and "Traceback" not in p.stderr
