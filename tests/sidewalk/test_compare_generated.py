"""`sidewalk compare --generated KIND:N`: the layouts written from their seeds, run with and without actors, judged per layout and in total."""

import asyncio
import json
import subprocess
import sys
from pathlib import Path

import pytest

from sidewalk.compare.comparison import CompareConfig, run_comparison
from sidewalk.compare.layouts import parse_generated, write_layouts
from sidewalk.compare.errors import CompareError
from sidewalk.compare.tables import render_markdown
from sidewalk.json_out import dumps
from sidewalk.report import build_report, write_report
from sidewalk.run_record import load_record

DATA = Path(__file__).parent / "data"


@pytest.mark.timeout(120)  # quiet run ~6 s
def test_layouts_are_written_from_their_seeds_the_same_each_time(tmp_path):
    a = write_layouts(parse_generated("suburb:2,marked-road:1"), tmp_path / "a")
    b = write_layouts(parse_generated("suburb:2,marked-road:1"), tmp_path / "b")
    assert [(x.kind, x.seed, Path(x.mission).name) for x in a] == [("suburb", 0, "suburb_0.yaml"), ("suburb", 1, "suburb_1.yaml"),
                                                                    ("marked-road", 0, "marked_road_0.yaml")]
    for x, y in zip(a, b):
        for f in ("mission", "world", "actors"):
            assert Path(getattr(x, f)).read_bytes() == Path(getattr(y, f)).read_bytes()
        assert Path(x.world).parent == tmp_path / "a" / "layouts" / x.kind
        assert (Path(x.world).parent / f"{Path(x.world).name.split('.')[0]}.map.geojson").exists()  # the robot's map beside it


@pytest.mark.parametrize("text, says", [("village:3", "unknown kind 'village'"), ("suburb", "expected KIND:N"),
                                        ("suburb:0", "N must be 1..1000")])
def test_a_bad_generated_spec_is_named(text, says):
    with pytest.raises(CompareError, match=says):
        parse_generated(text)


@pytest.mark.timeout(120)  # quiet run ~10 s (two processes that refuse)
@pytest.mark.parametrize("args, says", [(("--generated", "village:3"), "unknown kind 'village'"),
                                        (("--with-actors",), "give --generated"),
                                        (("--generated", "suburb:1", "--road-method", "lidar"), "unknown method 'lidar'")])
def test_bad_generated_flags_get_one_clear_line(args, says, tmp_path):
    r = subprocess.run([sys.executable, "-m", "sidewalk", "compare", *args, "--out", str(tmp_path)], capture_output=True, text=True,
                       timeout=100)
    assert r.returncode == 2 and says in " ".join(r.stderr.split()) and "Traceback" not in r.stderr


def _finished_run(out: Path, mission: str, *, success: bool, goal: float, collisions: int = 0, reason: str = "") -> None:
    """Write, where the comparison looks for it, the report of a recorded run as this cell's (as `--resume` takes it up)."""
    rep = build_report(load_record(DATA / "two-hop.run_record.json.gz")).model_copy(update={
        "mission": mission, "seed": 0, "success": success, "time_mode": "lockstep", "goal_error_m": goal,
        "collisions": collisions, "reason": reason, "architecture": "codger"})
    write_report(rep, out)


@pytest.mark.timeout(240)  # quiet run ~20 s (3 layouts written, glue counted)
def test_the_grid_over_layouts_reports_each_layout_and_the_totals(tmp_path):
    out = tmp_path / "cmp"
    layouts = write_layouts(parse_generated("suburb:3"), out)
    cfg = CompareConfig(missions=tuple(x.mission for x in layouts), seeds=(0,), architectures=("codger",), out=out, resume=True,
                        layouts=tuple(layouts), with_actors=True, road_method="yarf")
    runs = out / "runs" / "codger"
    for name, goal in (("suburb_0", 0.3), ("suburb_1", 0.5), ("suburb_2", 2.0)):
        _finished_run(runs / name / "seed0", name, success=goal < 1.5, goal=goal,
                      reason="" if goal < 1.5 else "stopped 2.0 m from the mailbox")
    _finished_run(runs / "suburb_0" / "seed0-actors", "suburb_0", success=False, goal=9.0, collisions=1,
                  reason="no progress along the route for 60 s")
    _finished_run(runs / "suburb_1" / "seed0-actors", "suburb_1", success=True, goal=0.4)
    _finished_run(runs / "suburb_2" / "seed0-actors", "suburb_2", success=True, goal=0.6)

    c = asyncio.run(run_comparison(cfg, ["codger"]))

    # every cell ran on its layout's own world, with its actors file in the second grid, with the road method asked for
    from sidewalk.compare.comparison import _cells

    cells = _cells(cfg, ["codger"], (0,)) + _cells(cfg, ["codger"], (0,), tag="-actors", missions=cfg.missions, with_actors=True)
    for cell in cells:
        argv = cell.argv(arch_flag=True)
        lay = next(x for x in layouts if x.mission == cell.mission)
        assert argv[argv.index("--world") + 1] == lay.world and argv[argv.index("--road-method") + 1] == "yarf"
        assert ("--actors" in argv) == cell.out.name.endswith("-actors")
        if cell.actors:
            assert argv[argv.index("--actors") + 1] == lay.actors
    rows = {(r.layout, r.actors): r for r in c.layouts}
    assert len(rows) == 6
    assert rows[("suburb_2", False)].success is False and "2.0 m from the mailbox" in rows[("suburb_2", False)].reason
    assert rows[("suburb_0", True)].collisions == 1 and rows[("suburb_0", True)].reason.startswith("no progress")
    totals = {t.actors: t for t in c.layout_totals}
    assert (totals[False].layouts, totals[False].successes, totals[False].collisions) == (3, 2, 0)
    assert totals[False].goal_error_median_m == 0.5 and totals[False].goal_error_p90_m == pytest.approx(1.7)
    assert (totals[True].successes, totals[True].collisions, totals[True].goal_error_median_m) == (2, 1, 0.6)
    assert c.summary["codger"].runs == 3  # the baseline: the runs without actors

    doc = json.loads(dumps(c.model_dump(mode="json")))
    assert len(doc["layouts"]) == 6 and len(doc["layout_totals"]) == 2
    md = render_markdown(c, "sidewalk compare --generated suburb:3 --with-actors")
    assert "## Generated layouts" in md
    assert "| suburb | codger | without | 2/3 | 0.50 | 1.70 | 0 |" in md
    assert "| suburb | codger | with | 2/3 | 0.60 |" in md
    assert "| suburb_0 | codger | with | 0 | ✘ | 9.00 | 1 | no progress along the route for 60 s |" in md
