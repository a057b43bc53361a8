"""End to end: `sidewalk run --arch eddie` drives a short mission with EDDIE's processes and no blackboard, judged by truth;
meanwhile `sidewalk status` says where the mission is, as the robot believes it (dead reckoning, without vision), and that moves."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.sidewalk._status import RunWatch, assert_cli_progress, assert_progress_moves

DATA = Path(__file__).resolve().parents[1] / "sidewalk" / "data"


@pytest.mark.e2e
@pytest.mark.missions  # a whole mission with its processes, so `make test-missions`
@pytest.mark.timeout(400)  # 29 s at load 6 (201 s before the status watch stopped waiting out its time-out)
def test_eddie_drives_a_short_mission_without_a_blackboard(tmp_path):
    cmd = [sys.executable, "-m", "sidewalk", "run", "--arch", "eddie", "--world", "campus", "--mission",
           str(DATA / "short-hop.yaml"), "--no-perception", "--rtf", "10", "--seed", "3", "--out", str(tmp_path),
           "--max-wall-time", "200"]
    watch = RunWatch(cmd)
    watch.wait_system(180)
    seen = watch.running_progress(timeout=200)
    proc = subprocess.CompletedProcess(cmd, watch.finish(timeout=280), "", watch.stderr())
    assert_progress_moves(seen)
    assert_cli_progress(watch.cli)
    assert any(p["waiting"] == "dead reckoning" for p in seen), seen  # the route driven without vision
    report_path = tmp_path / "report.json"
    assert report_path.exists(), f"no report; stderr:\n{proc.stderr[-3000:]}"
    report = json.loads(report_path.read_text())
    assert report["architecture"] == "eddie"
    assert report["success"], f"{report['reason']}\n{proc.stderr[-3000:]}"
    assert report["claimed_success"] and proc.returncode == 0
    assert report["collisions"] == 0 and report["goal_error_m"] < 1.5
    # arrival claimed at rest (the mission service's rule from the controller's odometry): where it stayed
    step = report["steps"][0]
    assert abs(step["distance_at_claim_m"] - step["distance_m"]) <= 0.1 and "at rest" in step["reason"], step
    assert 50.0 < report["distance_m"] < 110.0  # dorm (0,-28) → hall (30,8) over the walks
    # no blackboard anywhere: no process, no database, no counters
    logs = {p.stem for p in (tmp_path / "logs").glob("*.log")}
    assert {"sim", "controller", "navigator", "mission_service"} <= logs
    assert not {"blackboard", "captain", "pilot", "helm", "map_navigator"} & logs
    assert "blackboard" not in report["exit_codes"] and report["blackboard"] is None
    assert not (tmp_path / "blackboard.db").exists()
    # the estimate is the navigator's world←local ∘ the controller's local pose, sampled through the run
    assert report["position_error_m"]["n"] > 10
    assert all(code == 0 for code in report["exit_codes"].values()), report["exit_codes"]
