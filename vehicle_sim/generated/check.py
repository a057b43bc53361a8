"""The checks a generated street world must pass before it is used: read back, clear of the road, its route on the map.

Run on the written files, through the readers a run uses (`load_world` for the world and, as a map,
for the map; `load_actors` for the actors file): every roadside object keeps its least clearance
(`worldgen.ROADSIDE_CLEARANCE`; a campus passes its own table and path kinds) from every road and
intersection area of the world; every place the mission names is a place of the map; the map's path
graph joins the start to each destination under the step's constraints (no stairs under
`avoid_stairs` or for the Navlab, no slope under `avoid_slope`; edges cost length × the highest cost
of their path objects, as the ROUTE SELECTOR has it), by the route the generator drew; every actor's
waypoints in the lane lie on a path area. Truth only: this lives beside the simulator, never in
robot code. (The mission's schema is checked by the CAPTAIN's reader where `sidewalk worldgen`
writes it.)
"""

from __future__ import annotations

import heapq
from pathlib import Path

import shapely
import yaml

from vehicle_sim.actors import ActorError, load_actors
from vehicle_sim.errors import SimError
from vehicle_sim.worldfile import PathEdge, World, WorldFileError, load_world
from vehicle_sim.worldgen import ROADSIDE_CLEARANCE

__all__ = ["GeneratedWorldError", "clearance_problems", "shortest_route", "check_written"]

#: The kinds whose areas roadside objects keep clear of (streets; a campus passes its walkway kinds).
ROAD_KINDS = ("road", "intersection")


class GeneratedWorldError(SimError, ValueError):
    """A generated world failed its checks (the message names the file and each object or place at fault)."""


def _area_words(path_kinds: tuple[str, ...]) -> str:
    """Return 'a road or intersection area' for ("road", "intersection"); 'a sidewalk, intersection, slope or stairs area' for four."""
    return f"a {', '.join(path_kinds[:-1])} or {path_kinds[-1]} area" if len(path_kinds) > 1 else f"a {path_kinds[0]} area"


def clearance_problems(world: World, clearance: dict[str, float] = ROADSIDE_CLEARANCE,
                       path_kinds: tuple[str, ...] = ROAD_KINDS) -> list[str]:
    """Return one line per object of a kind in `clearance` standing closer [m] than it needs to an area of `path_kinds`."""
    roads = shapely.union_all([o.footprint for o in world.objects if o.kind in path_kinds])
    out = []
    for o in world.objects:
        need = clearance.get(o.kind)
        if need is None:
            continue
        d = float(o.footprint.distance(roads))
        if d < need:
            out.append(f"{o.kind} {o.id!r} is {d:.2f} m from {_area_words(path_kinds)}, less than the {need} m it needs")
    return out


def _usable(m: World, e: PathEdge, avoid_stairs: bool, avoid_slope: bool) -> bool:
    """Return whether edge `e` may be driven: not stairs under `avoid_stairs`, not a slope under `avoid_slope`."""
    kinds = {m.object(o).kind for o in e.path_objects if m.has_object(o)}
    stairs = e.mode == "climb-stairs" or "stairs" in kinds
    slope = e.mode == "go-through-slope" or "slope" in kinds
    return not ((stairs and avoid_stairs) or (slope and avoid_slope))


def _weight(m: World, e: PathEdge) -> float:
    """Return the cost of edge `e`: its length [m] × the highest cost of its path objects (1 without any)."""
    costs = [m.object(o).cost for o in e.path_objects if m.has_object(o)]
    return e.length * (max(costs) if costs else 1.0)


def shortest_route(m: World, start: str, goal: str, *, avoid_stairs: bool = False, avoid_slope: bool = False) -> list[str] | None:
    """Return the node ids of the cheapest way on `m`'s path graph from node `start` to node `goal`, or None.

    Edges cost length [m] × the highest cost of their path objects; stairs are left out under
    `avoid_stairs`, slopes under `avoid_slope`.
    """
    adj: dict[str, list[tuple[str, float]]] = {}
    for e in m.edges:
        if not _usable(m, e, avoid_stairs, avoid_slope):
            continue
        w = _weight(m, e)
        adj.setdefault(e.from_node, []).append((e.to_node, w))
        adj.setdefault(e.to_node, []).append((e.from_node, w))
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


def _step_avoids(mission: dict, step: dict) -> tuple[bool, bool]:
    """Return (avoid stairs, avoid slope) for a mission step as written: its constraints, and no stairs for the Navlab."""
    names = {c for c in step.get("constraints") or () if isinstance(c, str)}
    return "avoid_stairs" in names or mission.get("vehicle") == "navlab", "avoid_slope" in names


def check_written(world_path: Path, map_path: Path, mission_path: Path, actors_path: Path,
                  route: tuple[str, ...] | None = None, *, path_kinds: tuple[str, ...] = ROAD_KINDS,
                  clearance: dict[str, float] = ROADSIDE_CLEARANCE,
                  ways: tuple[tuple[tuple[str, ...], bool], ...] = ()) -> World:
    """Check the written files of one generated world; return the world, or raise GeneratedWorldError listing every problem.

    `route`: the node ids the first step's cheapest way must take; `path_kinds`: the areas objects keep
    `clearance` [m] from and actors walk or drive on; `ways`: further (node ids, avoid stairs) the map's
    cheapest way from the first node to the last must take, whatever the mission asks (a campus: up the
    stairs, and up the slope when stairs are avoided).
    """
    problems: list[str] = []
    try:
        world = load_world(world_path)
        m = load_world(map_path, kind="map")
    except WorldFileError as exc:
        raise GeneratedWorldError(f"{exc}") from None
    problems += [f"{world_path}: {p}" for p in clearance_problems(world, clearance, path_kinds)]
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
        avoid_stairs, avoid_slope = _step_avoids(mission, step)
        way = shortest_route(m, origin, places[dest], avoid_stairs=avoid_stairs, avoid_slope=avoid_slope)
        if way is None:
            under = " avoiding stairs" * avoid_stairs + " avoiding slopes" * avoid_slope
            problems.append(f"{map_path}: no way on the path graph from {origin!r} to {dest!r}{under}")
        elif route is not None and i == 0 and tuple(way) != tuple(route):
            problems.append(f"{map_path}: the shortest way to {dest!r} is {'-'.join(way)}, not the route drawn {'-'.join(route)}")
        origin = places[dest]
    for nodes, avoid_stairs in ways:
        got = shortest_route(m, nodes[0], nodes[-1], avoid_stairs=avoid_stairs)
        if got is None or tuple(got) != tuple(nodes):
            problems.append(f"{map_path}: the cheapest way from {nodes[0]!r} to {nodes[-1]!r}{' avoiding stairs' * avoid_stairs} is "
                            f"{'-'.join(got) if got else 'none'}, not {'-'.join(nodes)}")
    roads = shapely.union_all([o.footprint for o in world.objects if o.kind in path_kinds])
    way = "road" if "road" in path_kinds else "path"
    for a in actors.actors:
        on = [shapely.Point(w.x, w.y).distance(roads) < 0.05 for w in a.path]
        if a.kind == "car" and not all(on):
            problems.append(f"{actors_path}: actor {a.id!r}: a waypoint is off the {way}")
        if a.kind == "pedestrian" and not any(on):
            problems.append(f"{actors_path}: actor {a.id!r} never steps onto the {way}")
    if problems:
        raise GeneratedWorldError(f"{world_path.stem.removesuffix('.world')}: {len(problems)} problem(s)\n  " + "\n  ".join(problems))
    return world
