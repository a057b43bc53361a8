"""The comparison's statistics, measures, latencies, glue count and fault verdicts, on recorded data and real files."""

import math
from pathlib import Path

import numpy as np
import pytest

from sidewalk.compare import (
    CompareError, count_glue, logical_lines, measure_run, parse_fault, sense_to_act_s, spread, summarise, unit_latency_s,
    within_spread,
)
from sidewalk.compare.fault_outcome import judge_fault, recovery_s
from sidewalk.compare.latency import Latencies, LatencySeries
from sidewalk.compare.measures import RunMeasures
from sidewalk.compare.tables import fmt_spread
from sidewalk.report import build_report
from sidewalk.run_record import FaultEvent, load_record

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def record():
    return load_record(DATA / "two-hop.run_record.json.gz")


def test_spread_is_median_and_range_and_skips_missing():
    s = spread([3.0, None, 1.0, 10.0, float("nan")])
    assert (s.median, s.min, s.max, s.n) == (3.0, 1.0, 10.0, 3)
    assert spread([None]).median is None and spread([]).n == 0
    assert fmt_spread(s) == "3.00 [1.00–10.0]"
    assert fmt_spread(spread([2.0, 2.0])) == "2.00"


def test_within_spread_needs_each_median_inside_the_other_range():
    assert within_spread(spread([1, 2, 3]), spread([1.5, 2.5, 4]))
    assert not within_spread(spread([1, 2, 3]), spread([5, 6, 7]))
    assert not within_spread(spread([1, 2, 3]), spread([]))


def test_measures_of_a_recorded_run_match_its_report(record):
    rep = build_report(record)
    lat = Latencies(sense_to_act=LatencySeries.of(np.array([0.5, 1.5])), driving_unit=LatencySeries())
    m = measure_run(rep, lat)
    assert m.success == float(rep.success) == 0.0
    assert m.mission_time_s == rep.sim_time_s
    assert m.cpu_s == pytest.approx(sum(c.cpu_s for c in rep.modules.values()), abs=1e-3)
    assert m.cpu_s_modules < m.cpu_s  # the simulator and router are left out
    assert m.messages_per_s == pytest.approx(sum(c.msgs_out for c in rep.modules.values()) / rep.sim_time_s, rel=1e-3)
    assert m.sense_to_act_ms_p50 == 1000.0
    assert "sense_to_act_wall_ms_p50" not in RunMeasures.model_fields  # a sim figure over the RTF is no wall measurement
    # the lock-step barrier's asks and answers are the run mode's cost, counted apart from the modules' messages
    c = next(iter(rep.modules.values()))
    lock = rep.model_copy(update={"modules": {**rep.modules, "extra": c.model_copy(update={"msgs_out": c.msgs_out + 500, "barrier_msgs_out": 500})}})
    ml = measure_run(lock)
    assert ml.messages_per_s == pytest.approx(m.messages_per_s + c.msgs_out / rep.sim_time_s, rel=1e-3)
    assert ml.barrier_messages_per_s == pytest.approx(500 / rep.sim_time_s, rel=1e-3) and m.barrier_messages_per_s == 0.0
    assert m.mean_speed_m_s == pytest.approx(rep.distance_m / rep.sim_time_s, abs=1e-3)


def test_summary_per_architecture_keeps_each_apart(record):
    rep = build_report(record)
    a = measure_run(rep)
    b = a.model_copy(update={"architecture": "eddie", "success": 1.0, "cpu_s": a.cpu_s * 2})
    c = a.model_copy(update={"seed": 9, "cpu_s": a.cpu_s + 1})
    out = {s.architecture: s for s in summarise([a, b, c])}
    assert out["codger"].runs == 2 and out["codger"].success_rate == 0.0
    assert out["eddie"].success_rate == 1.0
    assert out["codger"].measures["cpu_s"].min == pytest.approx(a.cpu_s, abs=1e-3)
    assert out["codger"].cpu_s == pytest.approx(a.cpu_s + 0.5, abs=1e-3)
    assert summarise([a, b], mission="no-such-mission") == []


def test_sense_to_act_takes_the_first_command_per_capture():
    cmds = [(10.0, None), (10.1, 9.5), (10.2, 9.5), (11.0, 10.4), (11.1, 9.5), (11.2, None)]
    assert np.allclose(sense_to_act_s(cmds), [0.6, 0.6])
    assert unit_latency_s([("u0", 1.0), ("u1", 2.0), ("u0", 5.0)], [("u0", 1.75), ("u2", 3.0), ("u0", 9.0)]).tolist() == [0.75]


def test_fault_flags_are_parsed_or_named():
    f = parse_fault("wedge-planner@42.5")
    assert (f.name, f.at_s, f.flag()) == ("wedge-planner", 42.5, "wedge-planner@42.5")
    for bad in ("wedge-planner", "wedge-planner@", "wedge-planner@-1", "wedge-planner@x", "nap@3", "wedge-planner@inf", "wedge@3"):
        with pytest.raises(CompareError, match="--fault"):
            parse_fault(bad)


def test_recovery_follows_the_recorded_motion(record):
    truth = np.asarray(record.truth)
    moving = truth[np.r_[0.0, np.hypot(np.diff(truth[:, 1]), np.diff(truth[:, 2]))] > 1e-3]
    at = float(moving[len(moving) // 3, 0])
    r = recovery_s(record, at)
    assert r is not None and 0.0 <= r < 30.0
    assert recovery_s(record, float(truth[0, 0]) - 100.0) is None  # no motion before: nothing to recover to


def test_a_fault_run_is_judged_against_its_baseline(record):
    at = record.submitted_sim_s + 50.0
    rec = record.model_copy(update={"faults": (FaultEvent(name="wedge-planner", target="pilot", injected=True, at_sim_s=at),)})
    rep = build_report(rec)
    assert rep.faults[0].name == "wedge-planner"
    m = measure_run(rep)
    out = judge_fault(rep, rec, m, [m])
    assert out.verdict == "failed" and out.how == rep.reason and out.at_s == 50.0
    assert rep.collisions > 0
    crashed = judge_fault(rep.model_copy(update={"success": True}), rec, m, [m])
    assert crashed.verdict == "degraded" and "collision" in crashed.how
    ok = rep.model_copy(update={"success": True, "collisions": 0})
    assert judge_fault(ok, rec, m, [m]).verdict == "completed"
    slow = m.model_copy(update={"mission_time_s": rep.sim_time_s / 2})
    judged = judge_fault(ok, rec, m, [slow])
    assert judged.verdict == "degraded" and "without the fault" in judged.how
    missing = rec.model_copy(update={"faults": (FaultEvent(name="position-jump", injected=False, at_sim_s=at, detail="no part"),)})
    assert judge_fault(build_report(missing), missing, m, [m]).verdict == "not injected"


def test_logical_lines_skip_blanks_comments_and_docstrings():
    src = '"""Module doc\nover two lines."""\n\n# a comment\nx = (1,\n     2)  # trailing\n\n\ndef f():\n    """Doc."""\n    return x\n'
    assert logical_lines(src) == 4


def test_glue_is_what_touches_the_transport(tmp_path):
    pkg = tmp_path / "arch"
    (pkg / "algo").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "algo" / "__init__.py").write_text("")
    (pkg / "algo" / "plan.py").write_text("def plan(x):\n    return x + 1\n")
    (pkg / "link.py").write_text("from wire.session import open_session\n\nS = open_session\n")
    (pkg / "__main__.py").write_text("from arch.link import S\nfrom .algo.plan import plan\n\nS(plan(1))\n")
    (pkg / "unused.py").write_text("import wire.session\nY = 1\n")  # not reached from the entry point
    g = count_glue(tmp_path, "test", ["arch"])
    assert g.present
    assert set(g.glue_by_file) == {"arch/link.py", "arch/__main__.py"}
    assert (g.glue_lines, g.substrate_lines, g.algorithm_lines) == (5, 2, 2)
    assert not count_glue(tmp_path, "none", ["nothing"]).present


def test_a_file_is_glue_by_what_it_imports_itself_not_by_its_package(tmp_path):
    # a package whose __init__ touches the transport (as blackboard/__init__ does) and a pure data file beside it:
    # importing the data file by its dotted name runs the __init__, but does not make the data file glue
    pkg = tmp_path / "arch"
    (pkg / "bb").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "bb" / "__init__.py").write_text("from wire.session import open_session\n")
    (pkg / "bb" / "geometry.py").write_text("def area(w, h):\n    return w * h\n")
    (pkg / "bb" / "codec.py").write_text("from arch.bb.geometry import area\n\nA = area\n")
    (pkg / "bb" / "client.py").write_text("from arch.bb import open_session\n\nS = open_session\n")
    (pkg / "__main__.py").write_text("from arch.bb import open_session\nfrom arch.bb.codec import A\nfrom arch.bb.client import S\n\nS(A(1, 2))\n")
    g = count_glue(tmp_path, "test", ["arch"])
    assert set(g.glue_by_file) == {"arch/bb/__init__.py", "arch/bb/client.py", "arch/__main__.py"}
    assert set(g.algorithm_by_file) == {"arch/__init__.py", "arch/bb/geometry.py", "arch/bb/codec.py"}
    assert g.glue_lines == sum(g.glue_by_file.values()) and g.algorithm_lines == sum(g.algorithm_by_file.values())


def test_the_codger_glue_count_covers_the_blackboard_and_module_mains():
    root = Path(__file__).resolve().parents[2]
    g = count_glue(root, "codger")
    assert "blackboard/client.py" in g.glue_by_file and "codger/pilot/pilot.py" in g.glue_by_file
    assert "modules/pilot/kalman.py" not in g.glue_by_file  # an algorithm
    assert g.glue_lines > 0 and g.algorithm_lines > 0 and not math.isnan(g.glue_lines)


def test_compare_md_holds_every_table_and_names_what_did_not_run(record, tmp_path):
    from sidewalk.compare.comparison import SOURCE_ROOT, CompareConfig, Comparison, RunEntry
    from sidewalk.compare.fault_outcome import FaultOutcome
    from sidewalk.compare.plots import plot_comparison
    from sidewalk.compare.tables import render_markdown

    rep = build_report(record)
    m = measure_run(rep)
    runs = [RunEntry(architecture="codger", mission=rep.mission, seed=s, out=str(tmp_path), exit_code=1,
                     report=rep.model_dump(mode="json"), measures=m.model_copy(update={"seed": s})) for s in (0, 1)]
    runs.append(RunEntry(architecture="codger", mission=rep.mission, seed=2, out=str(tmp_path), exit_code=2, error="no report (exit 2)"))
    c = Comparison(config=CompareConfig(missions=(rep.mission,), seeds=(0, 1, 2), faults=("wedge-planner",)), available=["codger"],
                   requested=["codger", "eddie"], runs=runs, summary={s.architecture: s for s in summarise([r.measures for r in runs[:2]])},
                   per_mission=summarise([r.measures for r in runs[:2]], mission=rep.mission),
                   faults=[FaultOutcome(architecture="codger", mission=rep.mission, seed=0, fault="wedge-planner", injected=True,
                                        verdict="degraded", how="slower", at_s=40.0, recovery_s=3.5)],
                   glue=[count_glue(SOURCE_ROOT, "codger"), count_glue(SOURCE_ROOT, "eddie")])
    md = render_markdown(c, "sidewalk compare --seeds 3")
    for heading in ("## Outcome", "## Accuracy", "## Reaction", "## Cost", "## Runs", "## Faults", "## Lines of glue"):
        assert heading in md
    assert "Not run: eddie" in md and "no report" in md
    assert "| wedge-planner | codger |" in md and "degraded" in md
    assert "| wedge-planner | the module that plans the local path | pilot |" in md  # what the fault hits, said
    assert "## Appendix: the files counted" in md and "| codger/pilot/pilot.py | glue |" in md  # every counted file listed
    assert "| success rate (truth) | 0% |" in md
    files = plot_comparison(c, tmp_path)
    assert [f.name for f in files] == ["measures.png"] and files[0].stat().st_size > 10_000


def test_faults_come_in_pairs_that_take_the_same_role():
    from sidewalk.compare.faults import FAULTS, ROLES, TARGETS

    assert set(ROLES) == set(FAULTS)
    for arch in ("codger", "eddie"):
        assert set(TARGETS[arch]) == set(FAULTS), arch
    # the central piece: what every other module needs (not a service a module can drive without)
    assert (TARGETS["codger"]["kill-central"], TARGETS["eddie"]["kill-central"]) == ("blackboard", "controller")
    assert (TARGETS["codger"]["wedge-driver"], TARGETS["eddie"]["wedge-driver"]) == ("helm", "controller")
    assert (TARGETS["codger"]["wedge-planner"], TARGETS["eddie"]["wedge-planner"]) == ("pilot", "road_following")
    assert TARGETS["codger"]["kill-service"] is None and TARGETS["eddie"]["kill-service"] == "map_manager"
    with pytest.raises(CompareError, match="wedge-planner"):
        parse_fault("wedge@3")  # the old name says what it became
