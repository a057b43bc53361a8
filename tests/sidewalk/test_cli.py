"""The CLI's own errors: bad flags, files and names say where and what."""

import json

from typer.testing import CliRunner

from sidewalk.cli import app
from sidewalk.launcher import mission_path

runner = CliRunner()


def test_bad_pose_error_flag_is_named():
    r = runner.invoke(app, ["run", "--pose-error", "1.5"])
    assert r.exit_code == 2
    assert "--pose-error" in r.output and "M,DEG" in r.output


def test_bad_vehicle_is_named():
    r = runner.invoke(app, ["run", "--vehicle", "tank"])
    assert r.exit_code == 2 and "--vehicle" in r.output


def test_unknown_mission_lists_the_known_ones(tmp_path):
    r = runner.invoke(app, ["run", "--mission", "no-such-mission", "--out", str(tmp_path)])
    assert r.exit_code == 2
    assert "no mission named 'no-such-mission'" in r.output and "campus-tour" in r.output


def test_mission_for_another_world_is_refused(tmp_path):
    r = runner.invoke(app, ["run", "--world", "north_hills", "--mission", "campus-tour", "--out", str(tmp_path)])
    assert r.exit_code == 2 and "is for world 'campus'" in r.output


def test_invalid_mission_file_names_line_and_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("mission: x\nworld: campus\nsteps:\n  - name: a\n    destination: quad\n    constraints: [keep_middle]\n")
    r = runner.invoke(app, ["run", "--mission", str(bad), "--out", str(tmp_path / "out")])
    assert r.exit_code == 2
    out = " ".join(r.output.split())
    assert "bad.yaml:6:" in out and "steps[0].constraints.keep_middle" in out and "unknown constraint" in out


def test_bad_endpoint_flag_is_named():
    r = runner.invoke(app, ["status", "--connect", "localhost"])
    assert r.exit_code == 2 and "PROTO/ADDRESS" in r.output


def test_up_unknown_module_lists_the_known_ones():
    r = runner.invoke(app, ["up", "navigatorr"])
    assert r.exit_code == 2 and "map_navigator" in r.output


def test_mission_path_resolves_names_and_files(tmp_path):
    assert mission_path("campus-tour").name == "campus-tour.yaml"
    f = tmp_path / "m.yaml"
    f.write_text("x")
    assert mission_path(str(f)) == f


def test_bad_map_error_is_named():
    r = runner.invoke(app, ["run", "--map-error", "-1"])
    assert r.exit_code == 2 and "--map-error" in r.output and "distance >= 0" in r.output


def test_bad_sim_start_is_named():
    r = runner.invoke(app, ["sim", "serve", "--start", "1,2"])
    assert r.exit_code == 2 and "--start must be X,Y,YAW" in r.output


def test_a_benchmark_that_cannot_measure_says_why_without_a_traceback(monkeypatch):
    import bench.eddie
    from bench.errors import BenchError
    from eddie.errors import LinkTimeout

    for exc in (BenchError("the map manager never fired the first gate (20 states across it, 0.5 s apart)"),
                LinkTimeout("module 'controller': no reply to 'position' within 2 s")):
        def fail(**_kw):  # noqa: ANN202 - what bench.eddie.run raises when its processes do not answer
            raise exc

        monkeypatch.setattr(bench.eddie, "run", fail)
        r = runner.invoke(app, ["bench", "eddie", "--json", "--samples", "10"])
        assert r.exit_code == 1, r.output
        assert f"sidewalk bench eddie: could not measure: {exc}" in r.output
        assert "Traceback" not in r.output
        assert isinstance(r.exception, SystemExit)  # an exit with the message, not the error escaping
