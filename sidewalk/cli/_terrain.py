"""`sidewalk terrain …`: the elevation maps from ERIM images (buckets, the locus method) against the truth."""

from __future__ import annotations

import json
from typing import Annotated

import typer

__all__ = ["terrain_app"]

terrain_app = typer.Typer(help="Terrain from the laser: elevation maps scored against the truth raster.", no_args_is_help=True)


def _pair(text: str, flag: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise typer.BadParameter(f"{text!r} is not two numbers M,DEG", param_hint=flag) from None
    if a < 0 or b < 0:
        raise typer.BadParameter(f"{text!r}: both must be ≥ 0", param_hint=flag)
    return a, b


@terrain_app.command("eval")
def terrain_eval(
    world: Annotated[str, typer.Option(help="World name (worlds/<name>.world.geojson) or file, with terrain")] = "cross_country",
    images: Annotated[int, typer.Option(min=1, max=500, help="ERIM images along the track")] = 12,
    spacing: Annotated[float, typer.Option(min=0.2, max=20.0, help="Between images [m]")] = 2.0,
    resolution: Annotated[float, typer.Option(min=0.05, max=1.0, help="Map cell [m]")] = 0.1,
    within: Annotated[float, typer.Option(min=1.0, max=40.0, help="The near figures' reach from the sensor [m]")] = 20.0,
    vehicle: Annotated[str, typer.Option(help="navlab or terregator")] = "navlab",
    pose_noise: Annotated[str, typer.Option(help="Pose estimate error M,DEG: x/y sigma [m], yaw sigma [deg]")] = "0,0",
    seed: Annotated[int, typer.Option(help="Seed of sensor noise and pose errors")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
) -> None:
    """Drive a feasible track, map each ERIM image by buckets and by the locus method, score the maps against the truth."""
    from sidewalk.terrain_eval import TerrainEvalConfig, TerrainEvalError, evaluate
    from vehicle_sim.worldfile import WorldFileError, load_world

    if vehicle not in ("navlab", "terregator"):
        raise typer.BadParameter(f"{vehicle!r} is not navlab or terregator", param_hint="--vehicle")
    noise = _pair(pose_noise, "--pose-noise")
    try:
        w = load_world(world)
    except (FileNotFoundError, WorldFileError) as exc:
        raise typer.BadParameter(" ".join(str(exc).split())[:400], param_hint="--world") from None
    cfg = TerrainEvalConfig(images=images, spacing_m=spacing, resolution_m=resolution, within_m=within, vehicle=vehicle,
                            pose_noise=noise, seed=seed)
    try:
        rep = evaluate(w, cfg)
    except TerrainEvalError as exc:
        raise typer.BadParameter(str(exc), param_hint="--world") from None
    typer.echo(json.dumps(rep, sort_keys=True) if as_json else json.dumps(rep, indent=2, sort_keys=True))
