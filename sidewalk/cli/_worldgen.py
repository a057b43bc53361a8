"""`sidewalk worldgen KIND --seed N --out DIR`: write a generated world, its map and a mission (kinds: `vehicle_sim.generated`)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Optional

import typer

__all__ = ["register"]


def worldgen(
    kind: Annotated[str, typer.Argument(help="What to generate (cross-country, suburb, marked-road, campus)")],
    seed: Annotated[int, typer.Option(help="Seed: the same seed writes identical files")] = 0,
    out: Annotated[Path, typer.Option(help="Directory to write into")] = Path("runs/worldgen"),
    name: Annotated[Optional[str], typer.Option(help="The world's name (files NAME.world.geojson, …; default: KIND_SEED)")] = None,
) -> None:
    """Generate a world of KIND from a seed: the world and its map (with their terrain rasters) and a mission across it."""
    from vehicle_sim.errors import SimError
    from vehicle_sim.generated import GENERATORS

    if kind not in GENERATORS:
        raise typer.BadParameter(f"unknown kind {kind!r}; known: {', '.join(sorted(GENERATORS))}", param_hint="KIND")
    if name is not None and not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}", name):
        raise typer.BadParameter(f"{name!r}: letters, digits, '_' and '-' only (at most 64)", param_hint="--name")
    if out.exists() and not out.is_dir():
        raise typer.BadParameter(f"{out} exists and is not a directory", param_hint="--out")
    from modules.captain.missionfile import MissionFileError, load_mission

    try:
        paths = GENERATORS[kind](seed, out, name)
        for p in paths:
            if p.suffix == ".yaml" and not p.name.endswith(".actors.yaml"):
                load_mission(p)  # the mission by the CAPTAIN's own reader
    except (SimError, OSError, MissionFileError) as exc:
        typer.echo(f"error: sidewalk worldgen {kind} --seed {seed}: {exc}", err=True)
        raise typer.Exit(1) from None
    for p in paths:
        typer.echo(str(p))


def register(app: typer.Typer) -> None:
    """Add `worldgen` to the CLI."""
    app.command("worldgen")(worldgen)
