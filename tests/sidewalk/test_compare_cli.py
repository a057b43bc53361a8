"""`sidewalk compare`'s flags and its resume rule, without running a grid."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from sidewalk.compare.faults import FaultSpec
from sidewalk.compare.grid import GridRun, _finished, available_architectures
from sidewalk.report import build_report, write_report
from sidewalk.run_record import load_record

DATA = Path(__file__).parent / "data"


def _compare(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sidewalk", "compare", *args], capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("args, says", [
    (("--faults", "kill-perception,nap"), "unknown fault 'nap'"),
    (("--arch", "codger,soar"), "unknown architecture 'soar'"),
    (("--speed-sweep", "1,fast"), "not a list of speeds"),
    (("--missions", "no-such-mission"), "no mission named 'no-such-mission'"),
    (("--seeds", "0"), "--seeds and --jobs must be"),
])
def test_bad_flags_get_one_clear_line(args, says, tmp_path):
    r = _compare(*args, "--out", str(tmp_path))
    assert r.returncode == 2
    assert says in " ".join(r.stderr.split())
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "compare.json").exists()


def test_the_run_command_is_asked_which_architectures_it_runs():
    archs, flag = available_architectures()
    help_text = subprocess.run([sys.executable, "-m", "sidewalk", "run", "--help"], capture_output=True, text=True).stdout
    assert "codger" in archs
    assert flag == ("--arch" in help_text)
    assert ("eddie" in archs) == (flag and "eddie" in help_text)


def test_resume_reuses_only_a_report_of_the_same_cell(tmp_path):
    rep = build_report(load_record(DATA / "two-hop.run_record.json.gz"))
    write_report(rep, tmp_path)
    cell = GridRun(architecture="codger", mission=rep.mission, seed=rep.seed, rtf=8.0, out=tmp_path)
    assert _finished(cell) == (0 if rep.success else 1)
    assert _finished(cell.model_copy(update={"seed": rep.seed + 1})) is None
    assert _finished(cell.model_copy(update={"architecture": "eddie"})) is None
    assert _finished(cell.model_copy(update={"fault": FaultSpec(name="wedge-planner", at_s=3.0)})) is None
    assert _finished(cell.model_copy(update={"max_speed": 2.0})) is None
    (tmp_path / "report.json").write_text("{not json")
    assert _finished(cell) is None
    assert json.loads(json.dumps(cell.argv(arch_flag=True)))[-2:] == ["--arch", "codger"]


def test_every_fault_runs_unless_told_otherwise():
    from sidewalk.cli._compare import _fault_list
    from sidewalk.compare.faults import FAULTS

    assert _fault_list("all") == FAULTS == ("kill-central", "kill-service", "kill-perception", "wedge-driver", "wedge-planner", "position-jump")
    assert _fault_list("none") == ()
    assert _fault_list("wedge-planner, kill-central") == ("wedge-planner", "kill-central")
    help_text = subprocess.run([sys.executable, "-m", "sidewalk", "compare", "--help"], capture_output=True, text=True,
                               timeout=60, env={**__import__("os").environ, "COLUMNS": "300"}).stdout
    assert "default: all six; `none` to skip" in help_text
