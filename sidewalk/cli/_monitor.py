"""`sidewalk monitor`, `sidewalk replay`, `sidewalk record`: the NAVIGATION MONITOR page and MCAP recordings."""

# No `from __future__ import annotations`: Typer reads these annotations at run time.
from pathlib import Path
from typing import Annotated

import typer

from wire.flags import with_network
from wire.network import NetworkConfig

__all__ = ["register", "monitor", "replay", "record"]

_ARCHES = ("auto", "codger", "eddie")


def _check_arch(arch: str) -> None:
    if arch not in _ARCHES:
        raise typer.BadParameter(f"--arch must be one of {', '.join(_ARCHES)}, got {arch!r}")


def _check_port(port: int, host: str) -> None:
    from sidewalk.monitor.server import PortInUseError, check_port

    if not 0 < port < 65536:
        raise typer.BadParameter(f"--port must be 1-65535, got {port}")
    try:
        check_port(host, port)
    except PortInUseError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None


@with_network("peer", who="monitor")
def monitor(
    *,
    net: NetworkConfig,
    port: Annotated[int, typer.Option("--port", help="HTTP port of the page")] = 8080,
    host: Annotated[str, typer.Option("--host", help="Address to serve on (127.0.0.1: this machine only)")] = "127.0.0.1",
    arch: Annotated[str, typer.Option("--arch", help="auto, codger or eddie: which architecture's sources to follow")] = "auto",
) -> None:
    """Serve the NAVIGATION MONITOR: a live page of the map, route, driving units, poses, paths and module health."""
    from sidewalk.monitor.live import serve_live

    _check_arch(arch)
    _check_port(port, host)
    raise typer.Exit(serve_live(net, host=host, port=port, arch=arch))  # type: ignore[arg-type]


def replay(
    recording: Annotated[Path, typer.Argument(help="A recording (run.mcap) written by `sidewalk run` or `sidewalk record`")],
    speed: Annotated[float, typer.Option("--speed", help="Playback speed: sim seconds per wall second, relative to the recording")] = 1.0,
    port: Annotated[int, typer.Option("--port", help="HTTP port of the page")] = 8080,
    host: Annotated[str, typer.Option("--host", help="Address to serve on")] = "127.0.0.1",
) -> None:
    """Play a recording back into the NAVIGATION MONITOR page at `--speed` times sim speed."""
    import math

    from sidewalk.monitor.replay import serve_replay
    from sidewalk.recording import RecordingError, open_recording

    if not (math.isfinite(speed) and speed > 0):
        raise typer.BadParameter(f"--speed must be a positive number, got {speed}")
    try:
        rec = open_recording(recording)
    except RecordingError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    _check_port(port, host)
    raise typer.Exit(serve_replay(rec, host=host, port=port, speed=speed))


@with_network("peer", who="recorder")
def record(
    *,
    net: NetworkConfig,
    out: Annotated[Path, typer.Option("--out", help="The MCAP file to write (e.g. runs/latest/run.mcap)")] = Path("run.mcap"),
    arch: Annotated[str, typer.Option("--arch", help="codger (wait for the blackboard), eddie (none) or auto")] = "auto",
) -> None:
    """Record every message of a live system into an MCAP file until Ctrl-C (what every `sidewalk run` does)."""
    from sidewalk.recording.process import record as run_record

    _check_arch(arch)
    if out.exists() and out.is_dir():
        raise typer.BadParameter(f"{out} is a directory; give a file name such as {out / 'run.mcap'}", param_hint="--out")
    raise typer.Exit(run_record(net, out, arch=arch))  # type: ignore[arg-type]


def register(app: typer.Typer) -> None:
    """Add monitor, replay and record to the top-level app."""
    app.command("monitor")(monitor)
    app.command("replay")(replay)
    app.command("record")(record)
