"""The checks a generated street world must pass before it is used: read back, clear of the road, its route on the map.

Run on the written files, through the readers a run uses (`load_world` for the world and, as a map,
for the map; `load_actors` for the actors file): every roadside object keeps its least clearance
(`worldgen.ROADSIDE_CLEARANCE`) from every road and intersection area of the world; every place the
mission names is a place of the map; the map's path graph joins the start to each destination, by
the route the generator drew; every actor's waypoints in the lane lie on a road. Truth only: this
lives beside the simulator, never in robot code. (The mission's schema is checked by the CAPTAIN's
reader where `sidewalk worldgen` writes it.)
"""

from __future__ import annotations

import heapq
from pathlib import Path

import shapely
import yaml

from vehicle_sim.actors import ActorError, load_actors
from vehicle_sim.errors import SimError
from vehicle_sim.worldfile import World, WorldFileError, load_world
from vehicle_sim.worldgen import ROADSIDE_CLEARANCE

__all__ = ["GeneratedWorldError", "clearance_problems", "shortest_route", "check_written"]

#: The kinds whose areas roadside objects keep clear of.
ROAD_KINDS = ("road", "intersection")


class GeneratedWorldError(SimError, ValueError):
    """A generated world failed its checks (the message names the file and each object or place at fault)."""


def clearance_problems(world: World, clearance: dict[str, float] = ROADSIDE_CLEARANCE) -> list[str]:
    """Return one line per object of a kind in `clearance` standing closer [m] than it needs to a road or intersection area."""
    roads = shapely.union_all([o.footprint for o in world.objects if o.kind in ROAD_KINDS])
    out = []
    for o in world.objects:
        need = clearance.get(o.kind)
        if need is None:
            continue
        d = float(o.footprint.distance(roads))
        if d < need:
            out.append(f"{o.kind} {o.id!r} is {d:.2f} m from a road or intersection area, less than the {need} m it needs")
    return out


def shortest_route(m: World, start: str, goal: str) -> list[str] | None:
    """Return the node ids of the shortest way on `m`'s path graph from node `start` to node `goal`, or None."""
    adj: dict[str, list[tuple[str, float]]] = {}
    for e in m.edges:
        adj.setdefault(e.from_node, []).append((e.to_node, e.length))
        adj.setdefault(e.to_node, []).append((e.from_node, e.length))
    dist = {start: 0.0}
    prev: dict[str, str] = {}
    heap = [(0.0, start)]
    while heap:
        d, n = heapq.heappop(heap)
        if n == goal:
            path = [n]
            while path[-1] != start:
                path.append(prev[path[-1]])
            return path[::-1]
        if d > dist[n]:
            continue
        for nb, w in adj.get(n, ()):
            if d + w < dist.get(nb, float("inf")):
                dist[nb] = d + w
                prev[nb] = n
                heapq.heappush(heap, (d + w, nb))
    return None


def check_written(world_path: Path, map_path: Path, mission_path: Path, actors_path: Path,
                  route: tuple[str, ...] | None = None) -> World:
    """Check the written files of one generated world; return the world, or raise GeneratedWorldError listing every problem."""
    problems: list[str] = []
    try:
        world = load_world(world_path)
        m = load_world(map_path, kind="map")
    except WorldFileError as exc:
        raise GeneratedWorldError(f"{exc}") from None
    problems += [f"{world_path}: {p}" for p in clearance_problems(world)]
    try:
        mission = yaml.safe_load(mission_path.read_text())
        actors = load_actors(actors_path)
    except (OSError, yaml.YAMLError, ActorError) as exc:
        raise GeneratedWorldError(f"{mission_path}: {exc}") from None
    places = {n.name: n.id for n in m.nodes if n.name}
    origin = m.start.node if m.start is not None else None
    if origin is None or origin not in {n.id for n in m.nodes}:
        problems.append(f"{map_path}: the start names no node of the map ({origin!r})")
    for i, step in enumerate(mission.get("steps", [])):
        dest = step.get("destination")
        dest = dest.get("place") if isinstance(dest, dict) else dest
        if dest not in places:
            problems.append(f"{mission_path}: steps[{i}].destination {dest!r} is not a place of the map {map_path.name}")
            continue
        if origin is None:
            continue
        way = shortest_route(m, origin, places[dest])
        if way is None:
            problems.append(f"{map_path}: no way on the path graph from {origin!r} to {dest!r}")
        elif route is not None and i == 0 and tuple(way) != tuple(route):
            problems.append(f"{map_path}: the shortest way to {dest!r} is {'-'.join(way)}, not the route drawn {'-'.join(route)}")
        origin = places[dest]
    roads = shapely.union_all([o.footprint for o in world.objects if o.kind in ROAD_KINDS])
    for a in actors.actors:
        on = [shapely.Point(w.x, w.y).distance(roads) < 0.05 for w in a.path]
        if a.kind == "car" and not all(on):
            problems.append(f"{actors_path}: actor {a.id!r}: a waypoint is off the road")
        if a.kind == "pedestrian" and not any(on):
            problems.append(f"{actors_path}: actor {a.id!r} never steps onto the road")
    if problems:
        raise GeneratedWorldError(f"{world_path.stem.removesuffix('.world')}: {len(problems)} problem(s)\n  " + "\n  ".join(problems))
    return world
