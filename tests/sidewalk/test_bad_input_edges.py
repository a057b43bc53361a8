"""Bad input at the edges, as a user meets it (real `sidewalk` subprocesses): each mistake gets one line on
stderr saying what and where, a nonzero exit, no Python traceback, and never an echo of a huge file."""

import socket
from pathlib import Path

import pytest

from blackboard.testing import start_node
from modules.captain.missionfile import MAX_MISSION_BYTES, MAX_MISSION_STEPS
from tests.sidewalk._cli import one_line_error, sidewalk
from wire.ports import free_port

pytestmark = pytest.mark.timeout(120)


def test_a_binary_mission_file_is_named_in_one_line(tmp_path: Path):
    binary = tmp_path / "photo.yaml"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4)
    line = one_line_error(sidewalk("run", "--mission", str(binary), "--out", str(tmp_path / "o")), str(binary), "not UTF-8")
    assert line.startswith("error: ")
    # the same file to `sidewalk submit` is refused before anything is sent (no node, no CAPTAIN needed)
    one_line_error(sidewalk("submit", str(binary), "--connect", f"tcp/127.0.0.1:{free_port()}"), str(binary), "not UTF-8")


@pytest.mark.parametrize("flag,value", [("--rtf", "-1"), ("--map-error", "-1"), ("--max-wall-time", "0")])
def test_bad_numbers_name_their_flag(flag: str, value: str):
    one_line_error(sidewalk("run", flag, value), flag, value)


def test_a_huge_mission_file_is_refused_by_size_and_never_echoed(tmp_path: Path):
    huge = tmp_path / "huge.yaml"
    huge.write_text("mission: big\ndescription: " + "x" * 1_400_000 + "\nsteps: [{destination: quad}]\n")
    for p in (sidewalk("run", "--mission", str(huge), "--out", str(tmp_path / "o")),
              sidewalk("submit", str(huge), "--connect", f"tcp/127.0.0.1:{free_port()}")):
        line = one_line_error(p, str(huge), f"limit is {MAX_MISSION_BYTES} bytes")
        assert len(p.stderr) + len(p.stdout) < 600 and "xxxxxxxx" not in p.stderr + p.stdout, line


def test_a_20000_step_mission_is_refused_with_the_step_limit_named(tmp_path: Path):
    many = tmp_path / "many.yaml"
    # YAML aliases keep the file small: the step limit, not the size limit, refuses it
    many.write_text("mission: many\nsteps:\n  - &s {destination: quad}\n" + "  - *s\n" * 19_999)
    assert many.stat().st_size < MAX_MISSION_BYTES
    one_line_error(sidewalk("run", "--mission", str(many), "--out", str(tmp_path / "o")), str(many),
                   "20000 steps is too many", f"limit is {MAX_MISSION_STEPS} steps")


def test_an_unknown_destination_is_refused_before_anything_starts(tmp_path: Path):
    lost = tmp_path / "lost.yaml"
    lost.write_text("mission: lost\nworld: campus\nsteps:\n  - destination: quad\n  - destination: atlantis\n")
    one_line_error(sidewalk("run", "--mission", str(lost), "--out", str(tmp_path / "o")), str(lost),
                   "steps[1].destination", "unknown place 'atlantis'", "quad")
    assert not (tmp_path / "o" / "logs").exists()  # nothing was started


def test_a_port_in_use_is_one_line():
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        one_line_error(sidewalk("up", "router", "--listen", f"tcp/127.0.0.1:{port}"), f"127.0.0.1:{port}", "in use")


def test_a_database_another_node_holds_is_one_line(tmp_path: Path):
    db = tmp_path / "bb.db"
    with start_node(namespace="held", db=str(db)) as node:
        p = sidewalk("up", "blackboard", "--connect", node.endpoint, "--ns", "other", "--db", str(db))
        one_line_error(p, "--db", str(db), "held by another blackboard node")


def test_secure_on_a_directory_without_certificates_is_one_line(tmp_path: Path):
    empty = tmp_path / "no-certs"
    empty.mkdir()
    one_line_error(sidewalk("run", "--secure", str(empty), "--out", str(tmp_path / "o")), "--secure", str(empty), "missing")
