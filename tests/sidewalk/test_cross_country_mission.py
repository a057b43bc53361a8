"""End to end (issue 40): a short cross-country mission under CODGER — the MAP NAVIGATOR's off-road segment, the
TERRAIN module's tiles from the laser, the PILOT's cross-country plans on them, the HELM — each an OS process on
loopback Zenoh, in lock-step; the verdict from the simulator's truth (goal within 2 m, no collision, no tip-over,
no high-centring)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"


@pytest.mark.e2e
@pytest.mark.missions  # a whole mission, so `make test-missions`
@pytest.mark.timeout(1800)  # 205 s wall at load 5–8 (not measured quiet); a cold numba cache compiles the terrain code in three processes first
def test_a_short_cross_country_mission_succeeds_by_truth_under_codger(tmp_path) -> None:
    cmd = [sys.executable, "-m", "sidewalk", "run", "--mission", str(DATA / "cross-country-short.yaml"), "--arch", "codger",
           "--lockstep", "--seed", "1", "--out", str(tmp_path), "--max-wall-time", "1500", "--no-record"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1700)
    report_path = tmp_path / "report.json"
    assert report_path.exists(), f"no report (exit {proc.returncode}); stderr:\n{proc.stderr[-3000:]}"
    report = json.loads(report_path.read_text())
    pilot_log = (tmp_path / "logs" / "pilot.log").read_text()
    assert report["success"] and report["claimed_success"], f"{report['reason']}\n{pilot_log[-3000:]}"
    assert report["collisions"] == 0
    assert not {"tip-over", "high-centred"} & set(report["sim_events"]), report["sim_events"]
    step = report["steps"][0]
    assert step["distance_m"] <= step["tolerance_m"] == 2.0
    assert 35.0 < report["distance_m"] < 80.0  # it drove there, around what stood in the way
    assert "terrain" in report["modules"]
    assert proc.returncode == 0
