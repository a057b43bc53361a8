"""Bad input to the monitor, replay and record commands gets one clear line, before anything starts."""

import socket

import pytest
from typer.testing import CliRunner

from sidewalk.cli import app

runner = CliRunner()


@pytest.fixture()
def taken_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(1)
    try:
        yield s.getsockname()[1]
    finally:
        s.close()


def _one_line(r) -> str:
    return " ".join(r.output.split())


def test_replay_of_a_missing_or_foreign_file(tmp_path):
    r = runner.invoke(app, ["replay", str(tmp_path / "nope.mcap")])
    assert r.exit_code == 2 and f"no recording at {tmp_path / 'nope.mcap'}" in _one_line(r)
    (tmp_path / "report.json").write_text("{}")
    r = runner.invoke(app, ["replay", str(tmp_path / "report.json")])
    assert r.exit_code == 2 and "is not an MCAP file" in _one_line(r)
    r = runner.invoke(app, ["replay", str(tmp_path / "nope.mcap"), "--speed", "0"])
    assert r.exit_code == 2 and "--speed must be a positive number" in _one_line(r)


def test_monitor_on_a_port_in_use(taken_port):
    r = runner.invoke(app, ["monitor", "--port", str(taken_port)])
    assert r.exit_code == 2 and f"port {taken_port} on 127.0.0.1 is in use" in _one_line(r)
    r = runner.invoke(app, ["monitor", "--port", "70000"])
    assert r.exit_code == 2 and "--port must be 1-65535" in _one_line(r)
    r = runner.invoke(app, ["monitor", "--arch", "blackboard"])
    assert r.exit_code == 2 and "--arch must be one of auto, codger, eddie" in _one_line(r)


def test_run_with_the_monitor_on_a_port_in_use_stops_before_starting(taken_port, tmp_path):
    r = runner.invoke(app, ["run", "--mission", "campus-tour", "--out", str(tmp_path), "--monitor", "--monitor-port", str(taken_port)])
    assert r.exit_code == 2 and "is in use" in _one_line(r)
    assert not (tmp_path / "logs").exists()  # nothing was started
    r = runner.invoke(app, ["run", "--monitor", "--monitor-port", "0", "--out", str(tmp_path)])
    assert r.exit_code == 2 and "--monitor-port" in _one_line(r)


def test_record_refuses_a_directory_and_a_bad_arch(tmp_path):
    r = runner.invoke(app, ["record", "--out", str(tmp_path)])
    assert r.exit_code == 2 and "directory" in _one_line(r) and "--out" in _one_line(r)
    r = runner.invoke(app, ["record", "--arch", "x", "--out", str(tmp_path / "r.mcap")])
    assert r.exit_code == 2 and "--arch must be one of" in _one_line(r)


def test_bench_record_refuses_a_bad_arch_and_rtf():
    r = runner.invoke(app, ["bench", "record", "--arch", "blackboard"])
    assert r.exit_code == 2 and "--arch must be codger or eddie" in _one_line(r)
    r = runner.invoke(app, ["bench", "record", "--rtf", "0"])
    assert r.exit_code == 2 and "--rtf must be > 0" in _one_line(r)
