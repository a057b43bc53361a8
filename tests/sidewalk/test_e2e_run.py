"""End to end: `sidewalk run` starts the blackboard, the simulator and every module as OS processes
on loopback Zenoh, drives a short mission and writes a run record and a report judged from the truth."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"
REPORT_KEYS = {
    "architecture", "success", "claimed_success", "reason", "mission", "world", "vehicle", "seed", "map_error",
    "sim_time_s", "wall_time_s", "rtf_achieved", "distance_m", "steps", "cross_track_error_m",
    "cross_track_error_newest_m", "replans", "position_error_m", "goal_error_m", "collisions", "off_path_s",
    "blackboard", "modules",
}


def _run(out: Path, *extra: str) -> tuple[subprocess.CompletedProcess, dict]:
    cmd = [sys.executable, "-m", "sidewalk", "run", "--world", "campus", "--mission", str(DATA / "short-hop.yaml"),
           "--rtf", "25", "--seed", "3", "--out", str(out), "--max-wall-time", "240", *extra]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=420)
    report_path = out / "report.json"
    assert report_path.exists(), f"no report; stderr:\n{proc.stderr[-3000:]}"
    return proc, json.loads(report_path.read_text())


@pytest.mark.e2e
@pytest.mark.timeout(480)
def test_short_mission_with_every_module_in_its_own_process(tmp_path):
    proc, report = _run(tmp_path)
    assert REPORT_KEYS <= report.keys()
    logs = {p.stem for p in (tmp_path / "logs").glob("*.log")}
    assert {"blackboard", "sim", "helm", "perception", "pilot", "map_navigator", "captain"} <= logs
    assert report["success"], f"{report['reason']}\n{proc.stderr[-3000:]}"
    assert report["claimed_success"] and report["architecture"] == "codger"
    assert proc.returncode == 0
    assert report["collisions"] == 0
    assert [s["success"] for s in report["steps"]] == [True]
    assert report["steps"][0]["distance_m"] <= report["steps"][0]["tolerance_m"] == 1.5
    # step times are spans from the submission, within the mission's span
    assert 0.0 <= report["steps"][0]["started_s"] < report["steps"][0]["finished_s"] <= report["sim_time_s"]
    assert report["map_error"]["requested_m"] is None and report["map_error"]["path_max_m"] > 0
    # dorm (0,-28) → hall (30,8) over the walks is about 66 m
    assert 50.0 < report["distance_m"] < 110.0
    assert report["goal_error_m"] is not None and report["goal_error_m"] < 3.0
    assert report["blackboard"]["posts"] > 0 and report["blackboard"]["bytes"] > 0
    assert set(report["modules"]) >= {"router", "blackboard", "sim", "pilot", "helm", "perception", "captain", "map_navigator"}
    assert all(m["cpu_s"] > 0 and m["rss_mb"] > 10 and m["msgs_out"] > 0 for m in report["modules"].values())
    assert (tmp_path / "run_record.json").exists()
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000
    # every process was stopped cleanly by the launcher
    assert all(code == 0 for code in report["exit_codes"].values()), report["exit_codes"]
