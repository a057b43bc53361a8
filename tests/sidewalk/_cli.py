"""Running `sidewalk` as a user does (a real subprocess), and what one bad input must give: one line, no traceback."""

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest


def sidewalk(*args: str, timeout: float = 90) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sidewalk", *args], capture_output=True, text=True, timeout=timeout)


def one_line_error(p: subprocess.CompletedProcess, *needles: str) -> str:
    """Assert a nonzero exit with one stderr line holding every needle, and no traceback; return the line."""
    assert p.returncode != 0, p
    assert "Traceback" not in p.stderr and "Traceback" not in p.stdout, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


def run_report(out: Path, *args: str, wall_s: float) -> tuple[dict, str]:
    """Run `sidewalk run --out OUT ARGS…` and return its report and stderr; fail the test when it does not end within
    `wall_s` [s] wall (the launcher, sent SIGINT, stops every process it started) or writes no report."""
    proc = subprocess.Popen([sys.executable, "-m", "sidewalk", "run", "--out", str(out), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _, stderr = proc.communicate(timeout=wall_s)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)
        _, stderr = proc.communicate(timeout=90)
        pytest.fail(f"the run did not end within {wall_s:.0f} s wall; stderr:\n{stderr[-3000:]}")
    report_path = out / "report.json"
    assert report_path.exists(), f"no report; stderr:\n{stderr[-3000:]}"
    return json.loads(report_path.read_text()), stderr
