"""`sidewalk mapbuild`: drive a route by the robot's estimate, build a map of the discrete objects the laser finds, score it against truth."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from sidewalk.json_out import dumps

__all__ = ["register"]


def mapbuild(
    world: Annotated[str, typer.Option(help="World name (worlds/<name>.world.geojson) or file")] = "north_hills",
    route: Annotated[str, typer.Option("--route", "--mission", help="Mission whose route to drive (worlds/<name>.yaml or a file)")] = "amv-delivery",
    out: Annotated[Path, typer.Option(help="Map file to write (GeoJSON)")] = Path("runs/mapbuild/built.map.geojson"),
    vehicle: Annotated[str, typer.Option(help="terregator or navlab")] = "navlab",
    seed: Annotated[int, typer.Option(help="Seed of odometry and sensor noise")] = 0,
    actors: Annotated[str, typer.Option("--actors", help="Objects not on the map during the drive (file or preset)")] = "",
    speed: Annotated[float, typer.Option(min=0.5, help="Driving speed [m/s]")] = 4.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
) -> None:
    """Drive a route by the robot's own estimate from the map's start, track what the laser sees, write a map a later run can use (--map)."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from sidewalk.missions import mission_path
    from sidewalk.mapbuild import MapBuildReport, build_map, route_polyline, score_map, write_map
    from sidewalk.robot_map import map_beside
    from vehicle_sim.actors import ActorError, ActorSet, load_actors
    from vehicle_sim.worldfile import load_world

    if vehicle not in ("navlab", "terregator"):
        raise typer.BadParameter(f"{vehicle!r} is not navlab or terregator", param_hint="--vehicle")
    try:
        w = load_world(world)
        mpath = map_beside(world)  # the robot drives on its map, never on the world
        m = load_world(mpath, kind="map")
    except (FileNotFoundError, ValueError) as exc:
        raise typer.BadParameter(f"{exc}", param_hint="--world") from None
    try:
        mission = load_mission(mission_path(route))
    except (FileNotFoundError, MissionFileError) as exc:
        raise typer.BadParameter(f"{exc}", param_hint="--route") from None
    try:
        aset = w.actor_set() + (load_actors(actors) if actors else ActorSet())  # the world file's and the flag's
    except ActorError as exc:
        raise typer.BadParameter(str(exc), param_hint="--actors") from None
    if m.start is None:
        raise typer.BadParameter(f"the map {mpath} has no start pose", param_hint="--world")
    built = build_map(w, m, mission, actors=aset, vehicle=vehicle, seed=seed, speed=speed)
    out.parent.mkdir(parents=True, exist_ok=True)
    path = write_map(m, built, out, name=f"{w.name}-built")
    sc = score_map(w, built, route_polyline(m, mission))
    rep = MapBuildReport(frames=built.frames, distance_m=round(built.distance_m, 2), built_objects=len(built.objects),
                         dropped_moving=built.dropped_moving, dropped_spurious=built.dropped_spurious,
                         odometry_error_final_m=round(built.odometry_error_final_m, 3), perception_fixes=built.perception_fixes,
                         landmark_fixes=built.landmark_fixes, map_file=str(path), **sc)
    if as_json:
        typer.echo(dumps(rep.model_dump(mode="json"), sort_keys=True))
    else:
        typer.echo(rep.model_dump_json(indent=2))


def register(app: typer.Typer) -> None:
    """Add `mapbuild` to the CLI."""
    app.command("mapbuild")(mapbuild)
