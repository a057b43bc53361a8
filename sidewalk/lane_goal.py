"""Where the truth verdict judges a step: its destination, moved into the lane the step keeps to.

The lane is the world's: the route the mission asks for is found on the world's path graph (from
the mission's start, else the world's, then from each step's destination to the next), edges
costing their length × the highest cost of their path objects, stairs left out for the Navlab and
under `avoid_stairs`, slopes under `avoid_slope`, untraversable objects always. A step kept to a
side ends a quarter of the width of the path it arrives on to that side of its direction of travel
there (keep right on a 6 m walk: 1.5 m right of the centre line). The point is fixed per step before
the run starts: it never turns with the vehicle. This is the evaluator's own rule; no robot code
shares it. Frames: `world` [m].
"""

from __future__ import annotations

import heapq
import math
from typing import Optional, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict
from shapely import LineString, Point

from modules.vocabulary import Destination, MissionStepSpec, StepConstraints
from wire.mapfile import MapFile, PathEdge

__all__ = ["JudgedGoal", "Arrival", "judged_goals", "arrival"]


class JudgedGoal(BaseModel):
    """One step's judged point (x, y) [m] `world`, its lane's offset [m] left (+) of travel and the travel heading [rad] there."""

    model_config = ConfigDict(frozen=True)

    point: tuple[float, float]
    offset_m: float = 0.0
    heading: Optional[float] = None


class Arrival(BaseModel):
    """The last stretch of a route: the edge arrived on and the travel heading [rad] at the destination."""

    model_config = ConfigDict(frozen=True)

    edge: str
    heading: float


def _usable(edge: PathEdge, world: MapFile, constraints: StepConstraints, vehicle: str) -> bool:
    kinds = {world.object(o).kind for o in edge.path_objects if world.has_object(o)}
    stairs = edge.mode == "climb-stairs" or "stairs" in kinds
    slope = edge.mode == "go-through-slope" or "slope" in kinds
    blocked = any(world.has_object(o) and not math.isfinite(world.object(o).cost) for o in edge.path_objects)
    return not (blocked or (stairs and (vehicle == "navlab" or constraints.avoid_stairs)) or (slope and constraints.avoid_slope))


def _weight(edge: PathEdge, world: MapFile) -> float:
    """Return the cost [m] per metre of `edge`: the highest cost of its path objects (1 without any)."""
    costs = [world.object(o).cost for o in edge.path_objects if world.has_object(o)]
    return max(costs) if costs else 1.0


def _heading(coords: np.ndarray, s: float, forward: bool) -> float:
    """Return the heading [rad] of polyline `coords` (N, 2) at arc length `s` [m], travelled forward or backward.

    At a vertex the segment just travelled counts (the one before `s` going forward, after it going back).
    """
    seg = np.diff(coords, axis=0)
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(seg[:, 0], seg[:, 1]))])
    k = int(np.clip(np.searchsorted(cum, s, side="left" if forward else "right") - 1, 0, len(seg) - 1))
    dx, dy = seg[k] if forward else -seg[k]
    return math.atan2(dy, dx)


def _attach(world: MapFile, edges: Sequence[PathEdge], xy: tuple[float, float]) -> tuple[PathEdge, float]:
    """Return the usable edge nearest `xy` and the arc length [m] of `xy`'s projection on it."""
    p = Point(xy)
    e = min(edges, key=lambda e: LineString(e.coords).distance(p))
    return e, float(LineString(e.coords).project(p))


def arrival(world: MapFile, start_xy: tuple[float, float], dest: Destination, constraints: StepConstraints, *,
            vehicle: str) -> Optional[Arrival]:
    """Return the edge a route from `start_xy` to `dest` arrives on and the heading there (None: no route, or no travel)."""
    edges = [e for e in world.edges if _usable(e, world, constraints, vehicle)]
    if not edges:
        return None
    adj: dict[str, list[tuple[float, str, str, float, bool]]] = {}  # node → (cost, next node, edge, arc at arrival, forward)
    for e in edges:
        w = _weight(e, world) * e.length
        adj.setdefault(e.from_node, []).append((w, e.to_node, e.id, e.length, True))
        adj.setdefault(e.to_node, []).append((w, e.from_node, e.id, 0.0, False))
    se, ss = _attach(world, edges, start_xy)
    w0 = _weight(se, world)
    adj["<start>"] = [(ss * w0, se.from_node, se.id, 0.0, False), ((se.length - ss) * w0, se.to_node, se.id, se.length, True)]
    if dest.place is not None:
        goal = next((n for n in world.nodes if dest.place in (n.name, n.id)), None)
        if goal is None:
            return None
        target = goal.id
    else:
        ge, gs = _attach(world, edges, (float(dest.xy[0]), float(dest.xy[1])))
        wg = _weight(ge, world)
        target = "<goal>"
        adj.setdefault(ge.from_node, []).append((gs * wg, target, ge.id, gs, True))
        adj.setdefault(ge.to_node, []).append(((ge.length - gs) * wg, target, ge.id, gs, False))
        if ge.id == se.id and abs(gs - ss) > 1e-6:  # both on one edge: straight along it
            adj["<start>"].append((abs(gs - ss) * wg, target, ge.id, gs, gs > ss))
    best: dict[str, float] = {"<start>": 0.0}
    came: dict[str, tuple[str, float, bool]] = {}
    heap = [(0.0, "<start>")]
    while heap:
        d, n = heapq.heappop(heap)
        if n == target:
            break
        if d > best.get(n, math.inf):
            continue
        for w, nxt, eid, s, fwd in adj.get(n, ()):
            if d + w < best.get(nxt, math.inf) - 1e-12:
                best[nxt] = d + w
                came[nxt] = (eid, s, fwd)
                heapq.heappush(heap, (d + w, nxt))
    if target not in came:
        return None
    eid, s, fwd = came[target]
    return Arrival(edge=eid, heading=_heading(np.asarray(world.edge(eid).coords, float), s, fwd))


def judged_goals(world: MapFile, steps: Sequence[MissionStepSpec], destinations: Sequence[Optional[tuple[float, float]]],
                 start_xy: tuple[float, float], *, vehicle: str) -> tuple[Optional[JudgedGoal], ...]:
    """Return each step's judged point (None: a destination the world lacks), the route found from `start_xy` [m] on."""
    out: list[Optional[JudgedGoal]] = []
    at = start_xy
    for step, dest in zip(steps, destinations):
        if dest is None:
            out.append(None)
            continue
        keep = step.constraints.keep
        arr = arrival(world, at, step.destination, step.constraints, vehicle=vehicle) if world.edges else None
        if keep not in ("right", "left") or arr is None:
            out.append(JudgedGoal(point=dest, heading=None if arr is None else arr.heading))
        else:
            off = world.edge(arr.edge).width / 4.0 * (1.0 if keep == "left" else -1.0)
            h = arr.heading
            out.append(JudgedGoal(point=(dest[0] - off * math.sin(h), dest[1] + off * math.cos(h)), offset_m=off, heading=h))
        at = dest
    return tuple(out)
