"""The same mission twice in lock-step gives the same report (issue 10, item 5).

Both architectures repeat exactly: every figure of the two reports that does not measure wall time
is equal. EDDIE needed three things for it: its modules are handed their streams and inbox once per
tick, grouped by sender; a message is handed over at the first tick after the sim time it was sent
at (its stamp), not at whichever tick it happened to arrive before; and in lock-step every process
is a client of the router, so a message cannot still be on a direct peer link while the barrier's
asks find everyone idle (it repeated on a quiet machine but not beside a CPU hog before that).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"

#: report fields that measure wall time (or depend on it) and so differ between any two runs
WALL_FIELDS = {"wall_time_s", "rtf_achieved", "modules", "blackboard", "processes"}


def _run(out: Path, arch: str) -> dict:
    cmd = [sys.executable, "-m", "sidewalk", "run", "--arch", arch, "--mission", str(DATA / "short-hop.yaml"),
           "--seed", "4", "--lockstep", "--no-record", "--out", str(out), "--max-wall-time", "400"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=460)
    path = out / "report.json"
    assert path.exists(), f"no report; stderr:\n{proc.stderr[-3000:]}"
    return json.loads(path.read_text())


def _figures(report: dict) -> object:
    """Return the report without its wall-time fields, nor the sample counts `n` of its error summaries (the
    recorder, no barrier participant, may hear one truth sample more or less after the vehicle came to rest)."""
    def strip(v: object) -> object:
        if isinstance(v, dict):
            return {k: strip(x) for k, x in v.items() if k != "n"}
        if isinstance(v, list):
            return [strip(x) for x in v]
        return v

    return strip({k: v for k, v in report.items() if k not in WALL_FIELDS})


@pytest.mark.missions
@pytest.mark.timeout(1000)
@pytest.mark.parametrize("arch", ["codger", "eddie"])
def test_the_short_hop_twice_in_lockstep_gives_the_same_report(tmp_path: Path, arch: str) -> None:
    a, b = _run(tmp_path / "a", arch), _run(tmp_path / "b", arch)
    assert a["time_mode"] == b["time_mode"] == "lockstep"
    assert a["success"] and b["success"], (a["reason"], b["reason"])
    assert a["goal_error_m"] == b["goal_error_m"]
    assert _figures(a) == _figures(b)
