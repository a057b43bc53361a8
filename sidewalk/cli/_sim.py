"""`sidewalk sim …`: the simulator node (`serve`); other sim commands register on `sim_app` too."""

# No `from __future__ import annotations` here: `with_network` copies the signature without evaluating
# string annotations, so Typer would lose each option's names and help.
import os
import signal
import sys
import threading
from typing import Annotated

import typer

from wire.errors import WireError
from wire.network import NetworkConfig
from wire.flags import with_network
from wire.lifeline import dump_stacks_on_request

__all__ = ["sim_app"]

sim_app = typer.Typer(help="The Terregator/Navlab simulator: world, vehicle, sensors.", no_args_is_help=True)

_VEHICLES = ("terregator", "navlab")


@sim_app.command("serve")
@with_network("peer", who="sim")
def serve(
    *,
    net: NetworkConfig,
    world: Annotated[str, typer.Option("--world", "-w", help="World name (worlds/<name>.world.geojson) or file")] = "campus",
    vehicle: Annotated[str, typer.Option("--vehicle", help="terregator or navlab")] = "terregator",
    rtf: Annotated[float, typer.Option("--rtf", help="Real-time factor: sim seconds per wall second")] = 1.0,
    seed: Annotated[int, typer.Option("--seed", help="Seed of odometry noise, sensor noise and the served map")] = 0,
    map_error: Annotated[float, typer.Option("--map-error", help="Map error scale: 0 = perfect map, 1 = default error")] = 1.0,
    physics_hz: Annotated[float, typer.Option("--physics-hz", help="Physics steps per sim second")] = 100.0,
    publish_hz: Annotated[float, typer.Option("--publish-hz", help="Clock/odometry/truth messages per sim second")] = 20.0,
    watchdog: Annotated[float, typer.Option("--watchdog", help="Stop the vehicle after this many sim seconds without commands")] = 0.5,
    start: Annotated[str, typer.Option("--start", help="Start pose X,Y,YAW: world frame [m, m, deg CCW from +x] (default: the world's start)")] = "",
    actors: Annotated[str, typer.Option("--actors", help="Objects not on the map: an actors file (JSON/YAML) or a preset name")] = "",
    lockstep: Annotated[bool, typer.Option("--lockstep", help="Lock-step: hold at sim time 0 until released on sim/lockstep/release, then step only once every process started with SIDEWALK_LOCKSTEP=1 handled its inputs (no wall-clock pacing; --rtf unused)")] = False,
) -> None:
    """Serve the simulator over Zenoh until SIGINT/SIGTERM; prints a "ready" line once serving."""
    from pydantic import ValidationError

    from vehicle_sim.node import BARRIER_LINE, NodeConfig, SimNode
    from vehicle_sim.worldfile import WorldFileError, load_world

    if vehicle not in _VEHICLES:
        raise typer.BadParameter(f"--vehicle must be one of {', '.join(_VEHICLES)}, got {vehicle!r}")
    start_pose = _parse_pose(start, "--start") if start else None
    try:
        cfg = NodeConfig(vehicle=vehicle, rtf=rtf, seed=seed, physics_hz=physics_hz, publish_hz=publish_hz,  # type: ignore[arg-type]
                         watchdog_timeout=watchdog, map_error=map_error, start=start_pose,
                         actors=actors or None, lockstep=lockstep)
    except ValidationError as exc:
        msgs = "; ".join(f"--{str(e['loc'][0]).replace('_', '-')}: {e['msg']}" for e in exc.errors())
        raise typer.BadParameter(msgs) from None
    try:
        w = load_world(world)
    except FileNotFoundError as exc:
        raise typer.BadParameter(f"--world: {exc}") from None
    except WorldFileError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    try:
        node = SimNode(w, cfg, net)
    except ValueError as exc:  # ActorError is a ValueError: a bad actors file names itself
        raise typer.BadParameter(str(exc)) from None

    stop = threading.Event()

    def _on_signal(signum: int, frame: object) -> None:
        stop.set()
        node.request_stop()

    old = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    dump_stacks_on_request()
    try:
        try:
            node.start()
        except WireError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(3) from None
        typer.echo(f"ready sim world={w.name} vehicle={vehicle} {'lockstep' if lockstep else f'rtf={rtf:g}'} ns={net.namespace} keys={node.keys.base}/**")
        sys.stdout.flush()
        while not stop.is_set() and not node.wait(0.1):
            pass
    finally:
        node.stop()
        for s, h in old.items():
            signal.signal(s, h)
    ic = node.instants
    typer.echo(f"sim: captures rendered {ic.renders}, served again {ic.hits} ({ic.older} of an earlier instant)")
    if node.barrier is not None:  # one JSON object (wire.lockstep.BarrierStats): `sidewalk bench lockstep` reads it from the log
        typer.echo(f"{BARRIER_LINE}{node.barrier.stats.model_dump_json()}")
    if node.error is not None:
        typer.echo(f"simulator stopped: {type(node.error).__name__}: {node.error}", err=True)
    if not node.session_closed:
        print("sim: its Zenoh session did not close within 5 s; exiting without it (the simulator keeps no state)",
              file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(1 if node.error is not None else 0)  # an interpreter exit would wait for the session's threads
    if node.error is not None:
        raise typer.Exit(1)


def _parse_pose(text: str, flag: str = "--pose") -> tuple[float, float, float]:
    """Parse "X,Y,YAW" (x, y [m], yaw [deg] CCW from +x) into (x, y, yaw [rad])."""
    import math

    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 3:
        raise typer.BadParameter(f"{flag} must be X,Y,YAW (metres, metres, degrees), got {text!r}")
    try:
        x, y, yaw = (float(p) for p in parts)
    except ValueError:
        raise typer.BadParameter(f"{flag} must be three numbers X,Y,YAW, got {text!r}") from None
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        raise typer.BadParameter(f"{flag} values must be finite, got {text!r}")
    return x, y, math.radians(yaw)


@sim_app.command("render")
def render(
    world: Annotated[str, typer.Option("--world", "-w", help="World name (worlds/<name>.world.geojson) or file")] = "campus",
    pose: Annotated[str, typer.Option("--pose", help="Vehicle pose X,Y,YAW: world frame [m, m, deg CCW from +x]")] = ...,  # type: ignore[assignment]
    vehicle: Annotated[str, typer.Option("--vehicle", help="terregator or navlab (sensor mounting)")] = "navlab",
    seed: Annotated[int, typer.Option("--seed", help="Seed of the scene texture and sensor noise")] = 0,
    stamp: Annotated[float, typer.Option("--stamp", help="Sim time of the capture [s] (illumination drift)")] = 0.0,
    out: Annotated[str, typer.Option("--out", help="Output directory")] = ...,  # type: ignore[assignment]
    stereo: Annotated[bool, typer.Option("--stereo", help="Also FIDO's stereo pair: stereo_left.png, stereo_right.png")] = False,
) -> None:
    """Capture both sensors at one pose; write camera.png, range.png, labels.png, colored_range.png, map.png."""
    import numpy as np

    from vehicle_sim.render import write_render
    from vehicle_sim.scene import Scene
    from vehicle_sim.sensors import CaptureRequest, capture
    from vehicle_sim.worldfile import WorldFileError, load_world

    xyyaw = _parse_pose(pose)
    if vehicle not in _VEHICLES:
        raise typer.BadParameter(f"--vehicle must be one of {', '.join(_VEHICLES)}, got {vehicle!r}")
    try:
        w = load_world(world)
    except FileNotFoundError as exc:
        raise typer.BadParameter(f"--world: {exc}") from None
    except WorldFileError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    scene = Scene(w, seed=seed)
    res = capture(scene, xyyaw, stamp, CaptureRequest(stereo=stereo), vehicle=vehicle, rng=np.random.default_rng(seed))
    try:
        paths = write_render(out, scene, res)
    except OSError as exc:
        raise typer.BadParameter(f"--out: {exc}") from None
    for p in paths:
        typer.echo(str(p))
