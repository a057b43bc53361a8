"""`sidewalk roadfollow eval`: a short smoke of each method's figures, and user mistakes as one-line errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from sidewalk.cli import app
from sidewalk.roadfollow_eval import DrivePose, centre_at_origin, plan_drive, score_frame, summarise, to_vehicle
from modules.road_following import RoadObservation

KEYS = {"lateral_error_m_p50", "lateral_error_m_p95", "heading_error_deg_p50", "heading_error_deg_p95", "failure_rate",
        "ms_per_frame_p50"}


def test_truth_and_scores_of_a_known_frame() -> None:
    centre = np.array([[0.0, -50.0], [0.0, 50.0]])  # a road running north along x = 0
    pose = DrivePose(leg=0, x=1.0, y=0.0, yaw=math.pi / 2 + math.radians(5.0), stamp=0.0)
    c = to_vehicle(centre, pose)
    lat, hd = centre_at_origin(c)
    assert lat == pytest.approx(1.0 / math.cos(math.radians(5.0)), abs=1e-6)  # the centre is 1 m to the left
    assert math.degrees(hd) == pytest.approx(-5.0, abs=1e-6)
    good = RoadObservation(method="scarf", found=True, lateral_offset_m=lat + 0.2, heading_rad=hd, confidence=0.9, ms_per_frame=1.0)
    s = score_frame(good, c, 1.0)
    assert s is not None and s.lateral_err_m == pytest.approx(0.2) and s.heading_err_deg == pytest.approx(0.0, abs=1e-9)
    lost = good.model_copy(update={"found": False})
    fig = summarise([s, score_frame(lost, c, 1.0)])
    assert fig["failure_rate"] == 0.5 and fig["frames_with_road"] == 1 and KEYS <= set(fig)
    # ALVINN: steering straight ahead while the road is 1 m left at 12 m: the road point is off by ~1 m
    alv = RoadObservation(method="alvinn", found=True, steering_curvature_per_m=0.0, road_point=(12.0, 0.0), confidence=0.9,
                          ms_per_frame=0.1)
    c0 = to_vehicle(centre, DrivePose(leg=0, x=1.0, y=0.0, yaw=math.pi / 2, stamp=0.0))
    sa = score_frame(alv, c0, 0.1)
    assert sa is not None and sa.lateral_err_m == pytest.approx(1.0, abs=1e-6)
    assert sa.heading_err_deg == pytest.approx(math.degrees(math.asin(1.0 / 12.0)), abs=0.01)


def test_drive_plan_weaves_about_the_lane() -> None:
    rng = np.random.default_rng(0)
    poses = plan_drive([np.array([[0.0, 0.0], [100.0, 0.0]])], 50, rng, lane_offset_m=-1.75, weave_m=0.5, step_m=2.0)
    ys = np.array([p.y for p in poses])
    assert len(poses) == 50 and poses[1].x - poses[0].x == pytest.approx(2.0, abs=0.1) and ys.mean() == pytest.approx(-1.75, abs=0.15) and 0.3 < np.ptp(ys) / 2 <= 0.5 + 1e-9
    assert all(b.stamp > a.stamp for a, b in zip(poses, poses[1:]))


@pytest.mark.parametrize("method,limit_m", [("scarf", 0.4), ("yarf", 0.2)])
def test_eval_smoke(method: str, limit_m: float) -> None:
    out = CliRunner().invoke(app, ["roadfollow", "eval", "--method", method, "--frames", "12", "--seed", "3", "--json"])
    assert out.exit_code == 0, out.output
    r = json.loads(out.output)
    assert KEYS <= set(r) and r["frames"] == 12 and r["method"] == method
    assert r["failure_rate"] <= 0.2 and r["lateral_error_m_p50"] < limit_m and r["heading_error_deg_p50"] < 4.0
    assert r["ms_per_frame_p50"] > 0.0


def test_user_mistakes_are_one_line_errors(tmp_path) -> None:
    bad = CliRunner().invoke(app, ["roadfollow", "eval", "--method", "hough", "--json"])
    assert bad.exit_code != 0 and "hough" in bad.output and "Traceback" not in bad.output
    no_model = CliRunner().invoke(app, ["roadfollow", "eval", "--method", "alvinn"])
    assert no_model.exit_code != 0 and "--model" in no_model.output
    junk = tmp_path / "w.npz"
    junk.write_bytes(b"junk")
    bad_model = CliRunner().invoke(app, ["roadfollow", "eval", "--method", "alvinn", "--model", str(junk)])
    assert bad_model.exit_code != 0 and "w.npz" in bad_model.output and "Traceback" not in bad_model.output
    nowhere = CliRunner().invoke(app, ["roadfollow", "eval", "--method", "scarf", "--world", "nowhere"])
    assert nowhere.exit_code != 0 and "nowhere" in nowhere.output
    bad_data = CliRunner().invoke(app, ["roadfollow", "train", "--data", str(junk)])
    assert bad_data.exit_code != 0 and "w.npz" in bad_data.output
