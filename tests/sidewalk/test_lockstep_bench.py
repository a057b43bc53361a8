"""`sidewalk bench lockstep`: its flags are checked before anything runs, and a run that cannot start is named in one line."""

from __future__ import annotations

import subprocess
import sys

import pytest
from typer.testing import CliRunner

from sidewalk.cli import app

runner = CliRunner()


def _one_line(r) -> str:
    return " ".join((r.output or "").split())


def test_bench_lockstep_refuses_a_bad_arch_and_no_mission():
    r = runner.invoke(app, ["bench", "lockstep", "--arch", "codger,blackboard"])
    assert r.exit_code == 2 and "--arch takes codger and/or eddie" in _one_line(r)
    r = runner.invoke(app, ["bench", "lockstep", "--missions", " , "])
    assert r.exit_code == 2 and "--missions names no mission" in _one_line(r)


@pytest.mark.timeout(120)  # quiet ~2 s: one `sidewalk run` that stops at its mission file
def test_bench_lockstep_names_the_run_it_could_not_measure(tmp_path):
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench", "lockstep", "--json", "--arch", "codger",
                        "--missions", str(tmp_path / "nosuch.yaml"), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=100)
    assert p.returncode == 1 and "Traceback" not in p.stderr, p.stderr[-2000:]
    last = p.stderr.strip().splitlines()[-1]
    assert "could not measure: codger" in last and "nosuch.yaml seed 0: no report" in last and "does not exist" in last, last
