"""`sidewalk compare-check`: two grids of the same command held against each other, measure by measure."""

import json
import subprocess
import sys

from sidewalk.compare.repeat import check_repeat, load_summary, render_repeat
from sidewalk.compare.summary import ArchSummary, spread

CONFIG = {"missions": ["campus-tour"], "seeds": [0, 1, 2], "rtf": 8.0, "architectures": ["codger", "eddie"], "faults": ["wedge-planner"],
          "speeds": [], "out": "runs/x"}


def _grid(path, latency: list[float], verdict: str = "completed", highest: float | None = 2.0, *,
          byte_rates: tuple[float, ...] = (1e5, 1.1e5, 1.2e5), time_mode: str = "realtime") -> None:
    """Write a compare.json whose codger sense-to-act runs are `latency` [ms] (everything else alike)."""
    summary = {}
    for arch, lat in (("codger", latency), ("eddie", [900.0, 950.0, 1000.0])):
        measures = {"success": spread([1.0, 1.0, 1.0]), "sense_to_act_ms_p50": spread(lat), "bytes_per_s": spread(list(byte_rates))}
        summary[arch] = ArchSummary(architecture=arch, mission="*", runs=3, success_rate=1.0, measures=measures).model_dump(mode="json")
    faults = [{"architecture": a, "mission": "campus-tour", "seed": 0, "fault": "wedge-planner", "verdict": verdict if a == "codger" else "completed"}
              for a in ("codger", "eddie")]
    per_mission = [dict(v, mission="campus-tour") for v in summary.values()]  # one mission: the same figures
    path.mkdir()
    (path / "compare.json").write_text(json.dumps({"config": CONFIG, "time_mode": time_mode, "summary": summary, "per_mission": per_mission, "faults": faults,
                                                    "highest_speed": {"codger": highest, "eddie": 3.0}}))


def test_a_grid_within_the_others_spread_repeats_and_one_outside_does_not(tmp_path):
    _grid(tmp_path / "a", [1300.0, 1500.0, 1800.0])
    _grid(tmp_path / "b", [1250.0, 1450.0, 1700.0])  # medians 1500 and 1450: each inside the other's range
    _grid(tmp_path / "c", [1900.0, 2500.0, 3000.0], verdict="degraded", highest=1.0)  # median 2500 outside [1300–1800]
    a, b, c = (load_summary(tmp_path / n) for n in "abc")
    same = check_repeat(a, b, name_a="a", name_b="b")
    assert same.repeats and same.same_config and same.repeated == same.total == 2 * (2 * 3) + 2 + 2  # (all, per mission) × 2 archs × 3
    other = check_repeat(a, c, name_a="a", name_b="c")
    assert not other.repeats
    assert [(m.architecture, m.mission, m.measure) for m in other.measures if not m.repeats] == [
        ("codger", "*", "sense_to_act_ms_p50"), ("codger", "campus-tour", "sense_to_act_ms_p50")]
    assert {(v.architecture, v.a, v.b) for v in other.verdicts if not v.repeats} == {("codger", "completed", "degraded"),
                                                                                      ("codger", "2", "1")}
    md = render_repeat(other)
    assert "## Not repeated" in md and "| codger | * | sense_to_act_ms_p50 | 1,500 [1,300–1,800] | 2,500 [1,900–3,000] |" in md


def test_the_command_exits_by_the_verdict_and_names_a_bad_file(tmp_path):
    _grid(tmp_path / "a", [1300.0, 1500.0, 1800.0])
    _grid(tmp_path / "c", [1900.0, 2500.0, 3000.0])

    def check(*args):
        return subprocess.run([sys.executable, "-m", "sidewalk", "compare-check", *map(str, args)], capture_output=True, text=True,
                              timeout=60)

    assert check(tmp_path / "a", tmp_path / "a").returncode == 0
    r = check(tmp_path / "a", tmp_path / "c", "--json")
    assert r.returncode == 1 and json.loads(r.stdout)["repeats"] is False
    r = check(tmp_path / "a", tmp_path / "nowhere")
    assert r.returncode == 2 and "no such file" in " ".join(r.stderr.split()) and "Traceback" not in r.stderr  # the console wraps long paths
    (tmp_path / "bad.json").write_text('{"summary": {"codger": {"runs": "three"}}}')
    r = check(tmp_path / "a", tmp_path / "bad.json")
    assert r.returncode == 2 and "bad.json: summary.codger" in " ".join(r.stderr.split())


def test_between_lockstep_grids_the_machines_measures_are_shown_apart_and_not_counted(tmp_path):
    # the same simulated behaviour; bytes per sim second moved with the wall time the heartbeats took
    _grid(tmp_path / "a", [1300.0, 1500.0, 1800.0], time_mode="lockstep")
    _grid(tmp_path / "b", [1300.0, 1500.0, 1800.0], byte_rates=(2e5, 2.1e5, 2.2e5), time_mode="lockstep")
    _grid(tmp_path / "ra", [1300.0, 1500.0, 1800.0])
    _grid(tmp_path / "rb", [1300.0, 1500.0, 1800.0], byte_rates=(2e5, 2.1e5, 2.2e5))
    lock = check_repeat(load_summary(tmp_path / "a"), load_summary(tmp_path / "b"), name_a="a", name_b="b")
    assert lock.lockstep and lock.repeats and lock.total == 2 * 2 * 2 + 2 + 2 and lock.machine_total == 4
    assert lock.machine_repeated == 0  # both architectures' byte rates moved, and that is shown
    md = render_repeat(lock)
    assert "## Not repeated" not in md and "(machine, not counted)" in md and "4 measures of the machine" in md
    real = check_repeat(load_summary(tmp_path / "ra"), load_summary(tmp_path / "rb"), name_a="ra", name_b="rb")
    assert not real.lockstep and not real.repeats and real.machine_total == 0  # in real time every measure counts
