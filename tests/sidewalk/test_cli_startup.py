"""A quick command line: `sidewalk --help` and a `status` that finds nothing import no numpy, no pydantic models of
ours and no blackboard client; the list `--help` shows before importing is the commands' own; `bench cli` measures."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
import typer.main

from bench.cli import import_times
from sidewalk.cli import COMMANDS, app, load_command
from tests.modules._procs import spawn, stop
from wire.ports import free_port

#: Packages the quick paths must not import: what made every command take a second.
HEAVY = ("numpy", "blackboard", "modules", "eddie", "vehicle_sim", "sidewalk.launcher", "scipy", "shapely")


def _imported(args: list[str], ok: tuple[int, ...] = (0,)) -> set[str]:
    """Return every module a fresh `python -m sidewalk ARGS` imported (from `-X importtime`)."""
    p = subprocess.run([sys.executable, "-X", "importtime", "-m", "sidewalk", *args], capture_output=True, text=True,
                       env=dict(os.environ, COLUMNS="120"), timeout=60)
    assert p.returncode in ok, p.stderr[-2000:]
    return {ln.rsplit("|", 1)[1].strip() for ln in p.stderr.splitlines() if ln.startswith("import time:") and "|" in ln}


def _heavy(mods: set[str]) -> list[str]:
    return sorted(m for m in mods if m.split(".")[0] in HEAVY or m in HEAVY or m.startswith(HEAVY))


@pytest.fixture(scope="module")
def router():
    ep = f"tcp/127.0.0.1:{free_port()}"
    p = spawn([sys.executable, "-m", "sidewalk", "up", "router", "--ns", "clistart", "--listen", ep], "router ready")
    try:
        yield ep
    finally:
        stop(p)


@pytest.mark.timeout(60)  # quiet run ~3 s
def test_the_listed_commands_are_the_commands_themselves():
    group = typer.main.get_command(app)
    listed = group.list_commands(None)
    assert listed == [c.name for c in COMMANDS]
    for c in COMMANDS:
        real = load_command(c.name)
        assert real.name in (c.name, None, "") and (real.short_help or real.help or "").strip() == c.help, c.name


@pytest.mark.timeout(60)  # quiet run ~1 s
def test_help_imports_nothing_heavy():
    mods = _imported(["--help"])
    assert "typer" in mods and "sidewalk.cli" in mods
    assert not _heavy(mods), _heavy(mods)
    assert not any(m.startswith("sidewalk.cli._") for m in mods), sorted(m for m in mods if m.startswith("sidewalk.cli."))


@pytest.mark.timeout(60)  # quiet run ~2 s
def test_a_status_that_finds_only_the_router_imports_nothing_heavy_and_says_so(router):
    args = ["status", "--json", "--ns", "clistart", "--connect", router, "--heartbeat-wait", "0"]
    mods = _imported(args)
    assert "wire.aio" in mods and "wire.flags" in mods  # (importlib.import_module hides sidewalk.cli._run itself)
    assert not _heavy(mods), _heavy(mods)
    p = subprocess.run([sys.executable, "-m", "sidewalk", *args], capture_output=True, text=True, timeout=60)
    out = json.loads(p.stdout)
    assert p.returncode == 0 and [m["name"] for m in out["modules"]] == ["router"] and out["missions"] == [], p.stdout
    # another namespace: nothing alive at all, exit 1 and the hint
    p = subprocess.run([sys.executable, "-m", "sidewalk", "status", "--ns", "clistart-none", "--connect", router,
                        "--heartbeat-wait", "0"], capture_output=True, text=True, timeout=60, env=dict(os.environ, COLUMNS="200"))
    assert p.returncode == 1 and "nothing alive" in p.stdout, p.stdout + p.stderr


@pytest.mark.timeout(60)  # quiet run ~1 s
def test_a_typo_and_a_subapp_without_a_command_say_so_as_before():
    p = subprocess.run([sys.executable, "-m", "sidewalk", "stauts"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and "No such command 'stauts'. Did you mean 'status'?" in p.stderr, p.stderr
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench"], capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, COLUMNS="200"))
    assert "cli" in p.stdout and "blackboard" in p.stdout, p.stdout


def test_import_times_reads_the_top_level_entries():
    log = ("import time: self [us] | cumulative | imported package\n"
           "import time:       100 |        100 |     zipimport\n"
           "import time:       200 |      1500 |   encodings\n"
           "import time:      3000 |      9000 | typer\n"
           "import time:       500 |       700 | wire.errors\n")
    total, top = import_times(log)
    assert top == [("typer", 9.0), ("wire.errors", 0.7)]
    assert total == pytest.approx(0.0097)


@pytest.mark.timeout(480)  # quiet run ~10 s; 53 s and over 180 s measured at a load of 20 on 2 cores
def test_bench_cli_prints_its_figures():
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench", "cli", "--json", "--runs", "3"], capture_output=True,
                       text=True, timeout=170)
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout)
    for k in ("python_s", "help_s", "status_s", "status_no_wait_s", "help_cpu_s", "status_no_wait_cpu_s"):
        assert 0 < out[k]["p50"] <= out[k]["p95"], (k, out[k])
    assert out["help_import_s"] > 0 and out["help_import_top"][0][1] >= out["help_import_top"][-1][1]
    assert {n for n, _ms in out["status_import_top"]} & {"sidewalk.cli", "typer"}
