"""`sidewalk bench …`: benchmarks that print one JSON object each."""

from __future__ import annotations

import importlib
import os
from types import ModuleType
from typing import Annotated, Any

import typer

from sidewalk.json_out import dumps

__all__ = ["bench_app"]

bench_app = typer.Typer(help="Benchmarks; each prints one JSON object.", no_args_is_help=True)


def _measure(mod: ModuleType, **kw: Any) -> dict:
    """Return the benchmark module's `run(**kw)`; one that could not measure says why and exits 1 (no traceback).

    What it cannot measure: a process it needs that did not start or answer (`BenchError`), the
    blackboard or an EDDIE link failing with its typed error, a wait that timed out.
    """
    from bench.errors import BenchError
    from blackboard.errors import BlackboardError
    from eddie.errors import EddieError

    try:
        return mod.run(**kw)
    except (BenchError, BlackboardError, EddieError, TimeoutError) as exc:
        name = mod.__name__.rsplit(".", 1)[-1]
        typer.echo(f"sidewalk bench {name}: could not measure: {exc or type(exc).__name__}", err=True)
        raise typer.Exit(1) from None


def _emit(result: dict, as_json: bool) -> None:
    if as_json:
        typer.echo(dumps(result, sort_keys=True))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table("metric", "value")
    for k, v in sorted(result.items()):
        table.add_row(k, f"{v:.4g}" if isinstance(v, float) else str(v))
    Console().print(table)


@bench_app.command("blackboard")
def bench_blackboard(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    tokens: Annotated[int, typer.Option(help="Tokens in the store for the retrieve benchmark")] = 100_000,
    samples: Annotated[int, typer.Option(help="Samples per latency figure")] = 2000,
) -> None:
    """Blackboard node and client in separate processes, beside the raw-Zenoh floor."""
    mod = importlib.import_module("bench.blackboard")
    _emit(_measure(mod, tokens=tokens, samples=samples), as_json)


@bench_app.command("sim")
def bench_sim(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    world: Annotated[str, typer.Option(help="World name or file")] = "campus",
    frames: Annotated[int, typer.Option(help="Frames to render")] = 100,
) -> None:
    """Simulator render time, step time and the real-time factor reached."""
    mod = importlib.import_module("bench.sim")
    _emit(_measure(mod, world=world, frames=frames), as_json)


@bench_app.command("clock")
def bench_clock(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    rtf: Annotated[float, typer.Option(min=0.1, help="Real-time factor the simulator runs at")] = 50.0,
    seconds: Annotated[float, typer.Option(min=0.5, help="Wall time each figure is measured over [s]")] = 4.0,
) -> None:
    """What a module costs while it only waits on the sim clock, beside a bare Zenoh subscription to it."""
    mod = importlib.import_module("bench.clock")
    _emit(_measure(mod, rtf=rtf, seconds=seconds), as_json)


@bench_app.command("perception")
def bench_perception(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    world: Annotated[str, typer.Option(help="World name or file")] = "campus",
    frames: Annotated[int, typer.Option(min=1, help="Frames to process")] = 60,
    seed: Annotated[int, typer.Option(help="Seed for poses, sensor noise and pose errors")] = 0,
) -> None:
    """PERCEPTION's cycle time (captured frame to driving-unit result) at default resolution, with the IoU beside it."""
    mod = importlib.import_module("bench.perception")
    try:
        result = _measure(mod, world=world, frames=frames, seed=seed)
    except (FileNotFoundError, ValueError) as exc:
        raise typer.BadParameter(f"--world {world!r}: {exc}") from None
    _emit(result, as_json)


@bench_app.command("terrain-planner")
def bench_terrain_planner(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    vehicle: Annotated[str, typer.Option(help="navlab or terregator")] = "navlab",
    seeds: Annotated[str, typer.Option(help="Comma-separated seeds of the generated scenes")] = "1,2,3",
    repeats: Annotated[int, typer.Option(min=1, help="Plans per scene")] = 5,
) -> None:
    """A 50 m cross-country plan on 150k-cell generated maps: p50 ms, terrain queries, voxels per level; pyramid build ms."""
    if vehicle not in ("navlab", "terregator"):
        raise typer.BadParameter(f"must be navlab or terregator, got {vehicle!r}", param_hint="--vehicle")
    try:
        seed_list = tuple(int(s) for s in seeds.split(","))
    except ValueError:
        raise typer.BadParameter(f"must be comma-separated integers, got {seeds!r}", param_hint="--seeds") from None
    mod = importlib.import_module("bench.terrain_planner")
    _emit(_measure(mod, vehicle=vehicle, seeds=seed_list, repeats=repeats), as_json)


@bench_app.command("parallel")
def bench_parallel(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    world: Annotated[str, typer.Option(help="World of PERCEPTION's frames")] = "campus",
    frames: Annotated[int, typer.Option(min=2, help="Frames per algorithm")] = 12,
    rounds: Annotated[int, typer.Option(min=1, help="Times each frame is run (its median counts)")] = 3,
    seed: Annotated[int, typer.Option(help="Seed for poses and sensor noise")] = 0,
    max_workers: Annotated[int, typer.Option("--max-workers", min=0, max=64, help="Largest worker count (0: the machine's cores)")] = 0,
) -> None:
    """Parallel vision: time per frame and speed-up over 1, 2, 4 … workers per algorithm, beside the Warp's (issue 41)."""
    mod = importlib.import_module("bench.parallel")
    try:
        result = _measure(mod, world=world, frames=frames, rounds=rounds, seed=seed, max_workers=max_workers or None)
    except (FileNotFoundError, ValueError) as exc:
        raise typer.BadParameter(f"--world {world!r}: {exc}") from None
    _emit(result, as_json)


@bench_app.command("terrain")
def bench_terrain(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    world: Annotated[str, typer.Option(help="World name or file, with terrain")] = "cross_country",
    images: Annotated[int, typer.Option(min=1, max=500, help="ERIM images along the track")] = 30,
    seed: Annotated[int, typer.Option(help="Seed of sensor noise")] = 0,
) -> None:
    """The robot's elevation-map update per ERIM image (locus map, z registration, fusion), with the maps' accuracy beside it."""
    from sidewalk.terrain_eval import TerrainEvalError
    from vehicle_sim.worldfile import WorldFileError

    mod = importlib.import_module("bench.terrain")
    try:
        result = _measure(mod, world=world, images=images, seed=seed)
    except (FileNotFoundError, WorldFileError, TerrainEvalError) as exc:
        raise typer.BadParameter(" ".join(str(exc).split())[:400], param_hint="--world") from None
    _emit(result, as_json)


@bench_app.command("secure")
def bench_secure(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    samples: Annotated[int, typer.Option(min=10, help="Samples per latency figure")] = 1000,
) -> None:
    """The cost of --secure: post → monitor latency, plain peers vs plain clients vs TLS + passwords + access control."""
    mod = importlib.import_module("bench.secure")
    _emit(_measure(mod, samples=samples), as_json)


@bench_app.command("record")
def bench_record(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    mission: Annotated[str, typer.Option(help="Mission name or file (default: the tests' short mission)")] = "",
    rtf: Annotated[float, typer.Option(help="Real-time factor of the runs")] = 20.0,
    without: Annotated[bool, typer.Option("--without/--no-without", help="Also run the mission without the recorder")] = True,
    arch: Annotated[str, typer.Option(help="codger or eddie")] = "codger",
    perception: Annotated[bool, typer.Option("--perception/--no-perception", help="Run the perception modules")] = True,
    monitor: Annotated[bool, typer.Option("--monitor/--no-monitor",
                                          help="Also serve the monitor with one page open in headless chromium; measure its CPU")] = False,
    seed: Annotated[int, typer.Option(help="Seed of the runs")] = 3,
) -> None:
    """The recorder's CPU and the MCAP size per minute of sim (with and without the recorder); with --monitor, the monitor's CPU."""
    mod = importlib.import_module("bench.record")
    if rtf <= 0:
        raise typer.BadParameter(f"--rtf must be > 0, got {rtf}")
    if arch not in ("codger", "eddie"):
        raise typer.BadParameter(f"--arch must be codger or eddie, got {arch!r}")
    if monitor and not os.access(mod.CHROMIUM, os.X_OK):
        raise typer.BadParameter(f"--monitor needs Debian's chromium at {mod.CHROMIUM} (apt-get install -y chromium)")
    _emit(_measure(mod, mission=mission or mod.DEFAULT_MISSION, rtf=rtf, seed=seed, arch=arch, perception=perception, without=without,
                  monitor=monitor), as_json)


@bench_app.command("eddie")
def bench_eddie(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    samples: Annotated[int, typer.Option(help="Position queries (and floor gets) measured")] = 2000,
) -> None:
    """EDDIE's controller position queries beside the raw-Zenoh get floor and the map manager's trigger latency."""
    if samples < 10:
        raise typer.BadParameter(f"--samples must be ≥ 10, got {samples}")
    mod = importlib.import_module("bench.eddie")
    _emit(_measure(mod, samples=samples), as_json)


@bench_app.command("lockstep")
def bench_lockstep(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    missions: Annotated[str, typer.Option(help="Missions (comma-separated names or files)")] = "campus-tour,amv-delivery",
    arch: Annotated[str, typer.Option(help="Architectures (comma-separated: codger, eddie)")] = "codger,eddie",
    seed: Annotated[int, typer.Option(help="Seed of every run")] = 0,
    out: Annotated[str, typer.Option(help="Directory for the runs (default: a fresh temporary one)")] = "",
) -> None:
    """Lock-step RTF per architecture and mission (the comparison's runs), with CPU, traffic and barrier waves per sim second."""
    archs = tuple(a.strip() for a in arch.split(",") if a.strip())
    bad = [a for a in archs if a not in ("codger", "eddie")]
    if bad or not archs:
        raise typer.BadParameter(f"--arch takes codger and/or eddie, got {arch!r}")
    names = tuple(m.strip() for m in missions.split(",") if m.strip())
    if not names:
        raise typer.BadParameter("--missions names no mission")
    mod = importlib.import_module("bench.lockstep")
    _emit(_measure(mod, missions=names, archs=archs, seed=seed, out=out or None), as_json)


@bench_app.command("cli")
def bench_cli(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    runs: Annotated[int, typer.Option(min=3, help="Runs of each command measured")] = 20,
) -> None:
    """The command line's startup: `sidewalk --help` and a `status` that finds nothing (p50/p95 wall), and the slowest imports."""
    mod = importlib.import_module("bench.cli")
    _emit(_measure(mod, runs=runs), as_json)


@bench_app.command("soak")
def bench_soak(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    minutes: Annotated[float, typer.Option(help="How long to hold the rate [min wall]")] = 10.0,
    rate: Annotated[float, typer.Option(help="Posts per second [1/s]")] = 1000.0,
    monitors: Annotated[int, typer.Option(help="Monitors held open (each sees its share of the posts)")] = 20,
    keep: Annotated[int, typer.Option(help="Tokens kept in the store (the oldest beyond are deleted; 0: keep all)")] = 10_000,
) -> None:
    """A real blackboard node held at a post rate for minutes: lost notifications, p99 latency per minute, node RSS."""
    if not (minutes > 0 and rate > 0 and monitors >= 1 and keep >= 0):
        raise typer.BadParameter(f"wants --minutes > 0, --rate > 0, --monitors ≥ 1, --keep ≥ 0 "
                                 f"(got {minutes}, {rate}, {monitors}, {keep})")
    mod = importlib.import_module("bench.soak")
    _emit(_measure(mod, minutes=minutes, rate=rate, monitors=monitors, keep=keep), as_json)


@bench_app.command("fuzz")
def bench_fuzz(
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    payloads: Annotated[int, typer.Option(help="Generated payloads per key")] = 10_000,
    seed: Annotated[int, typer.Option(help="Seed of the payload generator")] = 0,
) -> None:
    """Generated payloads to every queryable and subscribed key of a live system; typed errors only, every process still serving."""
    if payloads < 1:
        raise typer.BadParameter(f"must be ≥ 1, got {payloads}", param_hint="--payloads")
    mod = importlib.import_module("bench.fuzz")
    result = _measure(mod, payloads=payloads, seed=seed)
    _emit(result, as_json)
    if result["violation_count"] or not all(result["still_serving"].values()) or not all(result["alive"].values()):
        raise typer.Exit(1)
