"""`--obstacle-sensor laser|fido` in each architecture's process plan, and a bad value refused in one line (issue 41).

No processes are started here; the missions driven with FIDO are in `test_fido_missions.py`."""

from pathlib import Path

import pytest

from typer.testing import CliRunner

from sidewalk.architecture import architecture
from sidewalk.cli import app
from sidewalk.launcher import RunConfig, prepare_run
from sidewalk.processes import UP_TARGETS

DATA = Path(__file__).resolve().parent / "data"


def _plans(tmp_path, arch: str, sensor: str | None):
    extra = {} if sensor is None else {"obstacle_sensor": sensor}
    cfg = RunConfig(world="campus", mission=str(DATA / "dorm-quad.yaml"), actors=str(DATA / "dorm-walker.actors.yaml"),
                    out=tmp_path, arch=arch, **extra)
    setup = prepare_run(cfg)
    a = architecture(arch)
    return {p.name: p.args for p in a.plans(cfg, setup, "ns", "tcp/127.0.0.1:7447", a.prepare(setup, tmp_path))}


def _up(args: tuple[str, ...]) -> str:
    return args[args.index("up") + 1]


def test_codger_runs_the_fido_detector_in_the_lasers_place(tmp_path):
    laser = _plans(tmp_path / "l", "codger", None)  # the default stays the laser
    assert "obstacles" in laser and "fido_obstacles" not in laser
    fido = _plans(tmp_path / "f", "codger", "fido")
    assert "fido_obstacles" in fido and "obstacles" not in fido
    assert UP_TARGETS[_up(fido["fido_obstacles"])] == "codger.fido_obstacles"


def test_eddie_runs_fido_obstacle_stop_under_obstacle_stops_name(tmp_path):
    laser = _plans(tmp_path / "l", "eddie", "laser")
    assert _up(laser["obstacle_stop"]) == "obstacle_stop"
    fido = _plans(tmp_path / "f", "eddie", "fido")
    args = fido["obstacle_stop"]  # the name the mission's triggers and the heartbeats know
    assert UP_TARGETS[_up(args)] == "eddie.fido_stop" and "--asleep" in args
    from eddie.fido_stop.__main__ import build_parser

    assert build_parser().parse_args([]).name == "obstacle_stop"


def test_a_bad_obstacle_sensor_is_one_line_naming_the_flag(tmp_path):
    res = CliRunner().invoke(app, ["run", "--obstacle-sensor", "sonar", "--out", str(tmp_path)])
    assert res.exit_code != 0 and "--obstacle-sensor" in res.output and "'sonar' is not laser or fido" in res.output
    assert "Traceback" not in res.output


def test_a_bad_fido_flag_is_one_line_naming_it(capsys):
    from eddie.fido_stop.__main__ import build_parser
    from modules.fido.obstacle_watch import FidoWatchConfig
    from modules.fido.watch_flags import watch_values
    from runtime.flags import config_from_flags

    parser = build_parser()
    assert config_from_flags(parser, FidoWatchConfig, watch_values(parser.parse_args(["--min-age", "2"]))).min_age == 2
    with pytest.raises(SystemExit):
        config_from_flags(parser, FidoWatchConfig, watch_values(parser.parse_args(["--min-age", "-1", "--stereo-size", "500"])))
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--min-age: " in err and "--stereo-size: " in err and "Traceback" not in err
