"""End to end: `sidewalk run` starts the blackboard, the simulator and every module as OS processes
on loopback Zenoh, drives a short mission and writes a run record and a report judged from the truth;
meanwhile `sidewalk status` says where the mission is, as the robot believes it, and that moves."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.sidewalk._status import RunWatch, assert_cli_progress, assert_progress_moves

DATA = Path(__file__).parent / "data"
REPORT_KEYS = {
    "architecture", "success", "claimed_success", "reason", "mission", "world", "vehicle", "seed", "map_error",
    "sim_time_s", "wall_time_s", "rtf_achieved", "distance_m", "steps", "cross_track_error_m",
    "cross_track_error_newest_m", "replans", "position_error_m", "goal_error_m", "collisions", "off_path_s",
    "blackboard", "modules",
}


def _run(out: Path, *extra: str) -> tuple[subprocess.CompletedProcess, dict, list[dict]]:
    """Run the short hop (at RTF 10: a few seconds of wall time to look at it while it drives); return the
    finished process, its report and what `sidewalk status` said about the running mission."""
    cmd = [sys.executable, "-m", "sidewalk", "run", "--world", "campus", "--mission", str(DATA / "short-hop.yaml"),
           "--rtf", "10", "--seed", "3", "--out", str(out), "--max-wall-time", "240", *extra]
    watch = RunWatch(cmd)
    watch.wait_system(180)
    seen = watch.running_progress(timeout=240)
    code = watch.finish(timeout=300)
    assert_cli_progress(watch.cli)
    report_path = out / "report.json"
    assert report_path.exists(), f"no report; stderr:\n{watch.stderr()[-3000:]}"
    return subprocess.CompletedProcess(cmd, code, "", watch.stderr()), json.loads(report_path.read_text()), seen


@pytest.mark.e2e
@pytest.mark.missions  # a whole mission with its processes, so `make test-missions`
@pytest.mark.timeout(400)  # 25 s at load 6 (242 s before the status watch stopped waiting out its time-out)
def test_short_mission_with_every_module_in_its_own_process(tmp_path):
    proc, report, seen = _run(tmp_path)
    assert_progress_moves(seen)
    assert REPORT_KEYS <= report.keys()
    logs = {p.stem for p in (tmp_path / "logs").glob("*.log")}
    assert {"blackboard", "sim", "helm", "perception", "pilot", "map_navigator", "captain"} <= logs
    assert report["success"], f"{report['reason']}\n{proc.stderr[-3000:]}"
    assert report["claimed_success"] and report["architecture"] == "codger"
    assert proc.returncode == 0
    assert report["collisions"] == 0
    assert [s["success"] for s in report["steps"]] == [True]
    assert report["steps"][0]["distance_m"] <= report["steps"][0]["tolerance_m"] == 1.5
    # arrival claimed at rest (the PILOT's rule from its odometry): where it claimed is where it stayed
    assert abs(report["steps"][0]["distance_at_claim_m"] - report["steps"][0]["distance_m"]) <= 0.1, report["steps"][0]
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
