"""A run of the comparison that wrote no report is a failed run: in the success rate, the tables and the plots."""

import asyncio
from pathlib import Path

import pytest

from sidewalk.compare.comparison import CompareConfig, run_comparison, summaries
from sidewalk.compare.plots import plot_comparison
from sidewalk.compare.tables import render_markdown
from sidewalk.report import build_report, write_report
from sidewalk.run_record import load_record

DATA = Path(__file__).parent / "data"

#: a mission on a world that does not exist: `sidewalk run` refuses it with one line and writes no report
LOST = """mission: lost
description: A hop on a world nobody shipped.
world: nowhere
vehicle: terregator
steps:
  - name: to the hall
    destination: hall
    constraints: [keep_right]
    trigger: stop
"""


@pytest.mark.timeout(120)  # ~29 s on a loaded machine (load 6 on 2 cores): one `sidewalk run` that refuses, the glue count
def test_a_baseline_run_without_a_report_lowers_the_success_rate(tmp_path):
    mission = tmp_path / "lost.yaml"
    mission.write_text(LOST)
    cfg = CompareConfig(missions=(str(mission),), seeds=(0, 1), architectures=("codger",), out=tmp_path / "cmp", resume=True)
    # seed 0 finished earlier and succeeded (a recorded run's report, as `--resume` takes it up); seed 1 runs now and
    # ends without a report: its world is missing
    rep = build_report(load_record(DATA / "two-hop.run_record.json.gz")).model_copy(
        update={"mission": "lost", "seed": 0, "success": True, "time_mode": "lockstep"})
    write_report(rep, cfg.out / "runs" / "codger" / "lost" / "seed0")

    c = asyncio.run(run_comparison(cfg, ["codger"]))

    lost = [r for r in c.runs if r.seed == 1]
    assert len(lost) == 1 and lost[0].report is None and lost[0].exit_code == 2
    assert "nowhere" in lost[0].error  # the run's own one-line reason
    s = c.summary["codger"]
    assert (s.runs, s.unreported, s.success_rate) == (2, 1, 0.5)  # not 1 of 1
    assert s.measures["success"].n == 2 and s.measures["success"].median == 0.5
    assert s.measures["mission_time_s"].n == 1  # a run without a report has no other figure
    assert [p.success_rate for p in c.per_mission] == [0.5]
    assert summaries(c.runs, cfg.missions)[0]["codger"] == s

    md = render_markdown(c)
    assert "| success rate (truth) | 50% |" in md
    assert "| of the runs, failed without a report | 1 |" in md
    assert "| codger | lost | 1 |  | ✘ no report |" in md
    files = plot_comparison(c, tmp_path / "plots")
    assert files[0].stat().st_size > 10_000
