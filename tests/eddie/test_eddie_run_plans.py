"""`sidewalk run --arch eddie`'s parts without a running system: the process plan, the belief composition, triggers in the report."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from eddie.toolkit.message import encode_body
from sidewalk.cli import app
from sidewalk.eddie_observe import LocalPoseView, TransformView, TriggerView, subscribe_eddie
from sidewalk.eddie_run import EDDIE_PERCEPTION_MODULES, PoseComposer, eddie_plans
from sidewalk.launcher import prepare_run
from sidewalk.report import build_report
from sidewalk.run_setup import RunConfig
from sidewalk.run_record import FiredTrigger, RunRecord
from wire.se2 import compose

DATA = Path(__file__).resolve().parents[1] / "sidewalk" / "data"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("eddie_plans")


def _plans_of(out: Path, annotated: Path | None = None, *, start_belief=None, map_file=None, **cfg_kw):
    """Return EDDIE's plans for a run of `cfg_kw` (the start belief and the robot's map replaced when given)."""
    cfg = RunConfig(**{"world": "campus", "mission": str(DATA / "short-hop.yaml"), "rtf": 8.0, "seed": 3, "watchdog_s": 1.0,
                       "arch": "eddie", "out": out, **cfg_kw})
    setup = prepare_run(cfg)
    update = {k: v for k, v in (("start_belief", start_belief), ("map_file", map_file)) if v is not None}
    return eddie_plans(cfg, setup.model_copy(update=update), "t1", "tcp/127.0.0.1:7447", annotated_map=annotated)


def _plans(out: Path, perception: bool, annotated: Path | None = Path("/tmp/x/annotated_map.geojson")):
    return _plans_of(out, annotated, start_belief=(1.0, -2.0, 0.5), perception=perception)


def test_the_eddie_plan_has_no_blackboard_and_the_perception_modules_only_with_perception(run_dir) -> None:
    names = [p.name for p in _plans(run_dir, True)]
    assert "blackboard" not in names and not any(n in names for n in ("captain", "pilot", "helm", "map_navigator"))
    assert names[:3] == ["router", "recorder", "sim"]
    assert {"controller", "navigator", "map_manager", "mission_service", *EDDIE_PERCEPTION_MODULES} <= set(names)
    blind = [p.name for p in _plans(run_dir, False)]
    assert not set(EDDIE_PERCEPTION_MODULES) & set(blind)
    ms = next(p for p in _plans(run_dir, False) if p.name == "mission_service")
    assert "--perception" in ms.args and ms.args[ms.args.index("--perception") + 1] == "off"
    nav = next(p for p in _plans(run_dir, False) if p.name == "navigator")
    assert "--start-pose=1.0,-2.0,0.5" in nav.args  # the start belief is the navigator's first world←local
    # the map manager starts empty, its state in the run's out dir: the mission service hands it the mission's annotations
    mm = next(p for p in _plans(run_dir, False, annotated=None) if p.name == "map_manager")
    assert "--annotated-map" not in mm.args and mm.args[mm.args.index("--state") + 1] == str(run_dir / "map_manager.state.json")


def test_a_speed_cap_reaches_the_route_speed_and_the_controllers_top_speed(run_dir) -> None:
    plans = _plans_of(run_dir, vehicle="navlab", perception=False, max_speed=1.5)
    by = {p.name: p.args for p in plans}
    assert by["controller"][by["controller"].index("--max-speed") + 1] == "1.5"
    assert by["mission_service"][by["mission_service"].index("--speed") + 1] == "1.5"
    assert "--max-speed" not in next(p for p in _plans(run_dir, False) if p.name == "controller").args


def test_the_controllers_speed_cap_lowers_the_trackers_top_speed_and_refuses_nonsense(capsys) -> None:
    from eddie.controller.__main__ import build_parser
    from modules.helm.tracker import tracker_config_for

    args = build_parser().parse_args(["--vehicle", "navlab", "--max-speed", "2"])
    assert args.max_speed == 2.0 and tracker_config_for("navlab").max_speed > 2.0
    from eddie.controller.__main__ import main
    with pytest.raises(SystemExit) as ex:
        main(["--vehicle", "navlab", "--max-speed", "-1", "--connect", "tcp/127.0.0.1:1"])
    assert ex.value.code == 2 and "--max-speed" in capsys.readouterr().err


def test_actors_go_to_the_simulator_and_obstacle_stop_sleeps_until_a_trigger(run_dir) -> None:
    plans = {p.name: p for p in _plans_of(run_dir, Path("/tmp/x/a.geojson"), map_file=Path("/tmp/built.map.geojson"),
                                          world="north_hills", mission="amv-delivery", vehicle="navlab", rtf=4.0, seed=0,
                                          perception=True, actors="amv-delivery")}
    sim = plans["sim"].args
    assert sim[sim.index("--actors") + 1] == "amv-delivery"
    assert "--asleep" in plans["obstacle_stop"].args and "--asleep" not in plans["road_following"].args
    for name in EDDIE_PERCEPTION_MODULES:  # the robot's map (here a built one) reaches every perception module
        assert plans[name].args[plans[name].args.index("--map") + 1] == "/tmp/built.map.geojson"
    assert "--actors" not in _plans(run_dir, True)[2].args


def test_the_belief_is_world_from_local_composed_with_the_local_pose() -> None:
    pc = PoseComposer()
    assert pc.world() is None
    pc.set_local(3.0, (2.0, 0.0, math.pi / 2))
    assert pc.world() is None  # no transform yet
    pc.set_world_from_local((10.0, 5.0, math.pi / 2))
    x, y, yaw = pc.world()
    want = compose(np.array([10.0, 5.0, math.pi / 2]), np.array([2.0, 0.0, math.pi / 2]))
    assert (x, y, yaw) == pytest.approx(tuple(want))
    assert (x, y) == pytest.approx((10.0, 7.0))


async def test_in_lockstep_the_belief_sampled_at_t_is_the_one_of_t_whatever_was_heard_since() -> None:
    import asyncio

    pc = PoseComposer(lockstep=True)
    pc.set_world_from_local((0.0, 0.0, 0.0), 0.0)  # the start
    pc.set_local(1.0, (1.0, 0.0, 0.0))
    pc.set_world_from_local((0.0, 2.0, 0.0), 1.1)  # a fix handled at the tick of 1.1: after the truth of 1.1
    pc.set_local(1.1, (1.1, 0.0, 0.0))
    pc.set_local(1.2, (1.2, 0.0, 0.0))  # heard before the sample was taken: must not count
    assert await pc.at(1.1) == pytest.approx((1.1, 0.0, 0.0))
    assert await pc.at(1.2) == pytest.approx((1.2, 2.0, 0.0))
    # the truth of 1.3 may arrive before the controller's pose of 1.3: the sample waits for it
    asyncio.get_running_loop().call_later(0.05, pc.set_local, 1.3, (1.3, 0.0, 0.0))
    assert await pc.at(1.3) == pytest.approx((1.3, 2.0, 0.0))
    assert pc.world() == pytest.approx((1.3, 2.0, 0.0))  # real time: the newest of each


def test_the_observer_views_read_the_streams_bare_fields_and_ignore_the_rest() -> None:
    from eddie.messages.controller import ControllerState
    from eddie.messages.navigator import WorldFromLocal
    from eddie.toolkit.message import decode_body

    st = ControllerState(stamp=4.0, x=1.0, y=2.0, yaw=0.3, v=0.8, curvature=0.0, client="road_following", mode="tracking")
    view = decode_body(LocalPoseView, encode_body(st))
    assert (view.stamp, view.x, view.y, view.yaw) == (4.0, 1.0, 2.0, 0.3)
    w = decode_body(TransformView, encode_body(WorldFromLocal(stamp=1.0, x=5.0, y=6.0, yaw=0.1, fixes_used=2)))
    assert (w.x, w.y, w.yaw) == (5.0, 6.0, 0.1)
    assert callable(subscribe_eddie) and TriggerView.model_fields["destination"].is_required()


def test_triggers_fired_reach_the_report_with_times_from_submission() -> None:
    rec = RunRecord.model_validate_json(gzip.decompress((DATA / "two-hop.run_record.json.gz").read_bytes()))
    t0 = rec.submitted_sim_s
    fired = (FiredTrigger(sim_s=t0 + 12.5, x=3.0, y=-20.0, annotation="a7", kind="set_speed", destination="controller",
                          text="3.0 m/s on the straight"),
             FiredTrigger(sim_s=t0 + 30.0, x=3.0, y=-5.0, annotation="a8", kind="dead_reckon", destination="road_following"))
    rep = build_report(rec.model_copy(update={"architecture": "eddie", "triggers": fired}))
    assert rep.architecture == "eddie"
    assert [(t.sim_s, t.kind, t.destination) for t in rep.triggers] == [(12.5, "set_speed", "controller"),
                                                                          (30.0, "dead_reckon", "road_following")]
    assert build_report(rec).triggers == []  # a CODGER record has none


def test_the_cli_refuses_an_unknown_architecture_and_lists_eddie_modules_for_up() -> None:
    r = CliRunner().invoke(app, ["run", "--arch", "blackboard2"])
    assert r.exit_code == 2 and "--arch" in r.output
    r = CliRunner().invoke(app, ["up", "no_such_module"])
    assert r.exit_code == 2 and "mission_service" in r.output and "road_following" in r.output


def test_each_steps_route_comes_back_from_the_annotated_map_for_cross_track(tmp_path: Path) -> None:
    from eddie.annotated_map.geojson_file import save_annotations
    from eddie.missions import compile_mission_files
    from sidewalk.eddie_run import route_plans

    c = compile_mission_files("worlds/campus-tour.yaml", "worlds/campus.map.geojson", vehicle="terregator")
    save_annotations(tmp_path / "am.geojson", c.annotations, name="campus-tour")
    plans = route_plans(tmp_path / "am.geojson", stamp=12.5)
    assert [p.step_index for p in plans] == [0, 1, 2, 3]
    assert all(p.revision == 0 and p.stamp == 12.5 for p in plans)
    for a, b in zip(plans, plans[1:]):  # each step starts where the last one ended
        assert math.dist(a.polyline[-1], b.polyline[0]) < 1e-6
    # the segments are joined in driving order without repeated points
    for p in plans:
        assert np.linalg.norm(np.diff(np.asarray(p.polyline), axis=0), axis=1).min() > 0.0
