"""`sidewalk eddie …`: EDDIE's annotated maps — compile a mission into one, list what a file holds."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Optional

import typer

from sidewalk.json_out import dumps

__all__ = ["eddie_app", "parse_polygon"]

eddie_app = typer.Typer(help="EDDIE: annotated maps (compile a mission into triggers, inspect a file).",
                        no_args_is_help=True)


def _fail(text: str, code: int = 2) -> typer.Exit:
    typer.echo(f"error: {text}", err=True)
    return typer.Exit(code)


def parse_polygon(text: str) -> tuple[tuple[float, float], ...]:
    """Return the ring [(x, y)] [m `world`] of `x,y,x,y,…` (≥ 3 points); raise ValueError naming what is wrong."""
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"{text!r}: expected numbers x,y,x,y,…") from None
    if len(vals) % 2 or len(vals) < 6:
        raise ValueError(f"{text!r}: expected at least 3 x,y pairs")
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"{text!r}: coordinates must be finite")
    return tuple(zip(vals[0::2], vals[1::2]))


@eddie_app.command("annotate")
def annotate(
    world: Annotated[str, typer.Option(help="World name (e.g. north_hills) or world file; its map file (NAME.map.geojson beside it) is used, never the world")],
    mission: Annotated[str, typer.Option(help="Mission name from worlds/ or a mission YAML file")],
    out: Annotated[Path, typer.Option(help="Annotated map file to write (GeoJSON)")],
    map_file: Annotated[Optional[Path], typer.Option("--map", help="Map file to route on (default: the world's)")] = None,
    vehicle: Annotated[Optional[str], typer.Option(help="terregator or navlab (default: the mission's)")] = None,
    intersections: Annotated[str, typer.Option(help="dead-reckon (then resume vision) or vision through intersections")] = "dead-reckon",
) -> None:
    """Compile a mission into trigger annotations along its route and write them as GeoJSON."""
    from eddie.annotated_map import save_annotations
    from eddie.messages.map_manager import open_trigger_data
    from eddie.missions import MissionCompileError, compile_mission_files
    from sidewalk.missions import mission_path
    from sidewalk.robot_map import map_beside

    if vehicle is not None and vehicle not in ("terregator", "navlab"):
        raise _fail(f"--vehicle: {vehicle!r}: expected terregator or navlab")
    if intersections not in ("dead-reckon", "vision"):
        raise _fail(f"--intersections: {intersections!r}: expected dead-reckon or vision")
    try:
        mpath = mission_path(mission)
        mfile = map_file if map_file is not None else map_beside(world)
        if not Path(mfile).exists():
            raise FileNotFoundError(f"--map: {mfile} does not exist")
    except FileNotFoundError as exc:
        raise _fail(str(exc)) from None
    try:
        compiled = compile_mission_files(mpath, mfile, vehicle=vehicle, intersections=intersections.replace("-", "_"))
    except MissionCompileError as exc:
        raise _fail(str(exc)) from None
    try:
        save_annotations(out, compiled.annotations, name=f"{compiled.mission} on {compiled.map_name}")
    except OSError as exc:
        raise _fail(f"--out: {out}: {exc.strerror or exc}") from None
    n_trig = sum(1 for a in compiled.annotations if a.trigger != "none")
    speeds = sorted({open_trigger_data(a.data).speed for a in compiled.annotations if a.type == "route"})  # type: ignore[attr-defined]
    typer.echo(f"{out}: {len(compiled.annotations)} annotations ({n_trig} triggers) for {compiled.mission} on "
               f"{compiled.map_name} ({compiled.vehicle}); route speeds {', '.join(f'{s:g}' for s in speeds)} m/s")


@eddie_app.command("annotations")
def annotations(
    file: Annotated[Path, typer.Argument(help="Annotated map file (GeoJSON)")],
    type_: Annotated[Optional[str], typer.Option("--type", help="Only annotations of this type")] = None,
    within: Annotated[Optional[str], typer.Option(help="Only annotations within polygon x,y,x,y,… [m world]")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON array instead of a table")] = False,
) -> None:
    """List the annotations of a file: every one of --type within --within (both optional)."""
    from eddie.annotated_map import AnnotatedMapError, AnnotationDatabase, load_annotations
    from eddie.messages.map_manager import open_trigger_data

    poly = None
    if within is not None:
        try:
            poly = parse_polygon(within)
        except ValueError as exc:
            raise _fail(f"--within: {exc}") from None
    try:
        db = AnnotationDatabase(load_annotations(file))
    except AnnotatedMapError as exc:
        raise _fail(str(exc)) from None
    hits = db.query(type_, poly)
    if as_json:
        rows = []
        for a in hits:
            row = a.model_dump(mode="json", exclude={"data"})
            row["data_size"] = a.data_size
            try:
                d = open_trigger_data(a.data) if a.data else None
                row["data"] = None if d is None else {"message": type(d).__name__, **d.model_dump(mode="json")}
            except Exception:  # noqa: BLE001 - opaque data need not be a message
                row["data"] = None
            rows.append(row)
        typer.echo(dumps(rows))
        return
    for a in hits:
        x0, y0, x1, y1 = a.location.bounds()
        typer.echo(f"{a.id:40s} {a.type:26s} {a.trigger:6s} → {a.destination or '-':10s} "
                   f"{a.location.kind:7s} ({(x0 + x1) / 2:8.1f}, {(y0 + y1) / 2:8.1f})  {a.text}")
    typer.echo(f"{len(hits)} of {len(db)} annotations")
