"""End to end: `sidewalk run --arch eddie` drives a short mission with EDDIE's processes and no blackboard, judged by truth."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "sidewalk" / "data"


@pytest.mark.e2e
@pytest.mark.timeout(300)
def test_eddie_drives_a_short_mission_without_a_blackboard(tmp_path):
    cmd = [sys.executable, "-m", "sidewalk", "run", "--arch", "eddie", "--world", "campus", "--mission",
           str(DATA / "short-hop.yaml"), "--no-perception", "--rtf", "25", "--seed", "3", "--out", str(tmp_path),
           "--max-wall-time", "200"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=280)
    report_path = tmp_path / "report.json"
    assert report_path.exists(), f"no report; stderr:\n{proc.stderr[-3000:]}"
    report = json.loads(report_path.read_text())
    assert report["architecture"] == "eddie"
    assert report["success"], f"{report['reason']}\n{proc.stderr[-3000:]}"
    assert report["claimed_success"] and proc.returncode == 0
    assert report["collisions"] == 0 and report["goal_error_m"] < 1.5
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
