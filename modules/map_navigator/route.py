"""The ROUTE SELECTOR's search: the cheapest route on the path graph under the step's constraints.

Edges cost length × the highest cost multiplier of their path objects; stairs edges are impassable
for the Navlab and under avoid_stairs, slope edges under avoid_slope. Start and goal points off the
graph's nodes are projected onto the nearest usable edge. World frame, metres.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import shapely
import shapely.ops
from wire.mapfile import PathEdge

from modules.map_navigator.mapdata import MapData
from modules.vocabulary import Destination, StepConstraints
from modules.map_navigator.errors import MapNavigatorError

__all__ = [
    "RouteError", "UnknownPlaceError", "NoRouteError", "Leg", "Route", "RouteOptions", "edge_cost",
    "select_route", "edge_forbidden", "drop_doubling_back",
]

Vehicle = Literal["terregator", "navlab"]


class RouteError(MapNavigatorError, ValueError):
    """No route can be given for the step; the message is the reason reported to the CAPTAIN."""


class UnknownPlaceError(RouteError):
    """The destination names no place of the map."""


class NoRouteError(RouteError):
    """No path on the graph reaches the destination under the constraints."""


@dataclass(frozen=True)
class RouteOptions:
    """Route selection settings: the vehicle, edges to avoid (failed before), snap and reach distances [m].

    `retreat` is the direction of travel (dx, dy) when a segment failed: the start may still attach
    to a blocked edge, but only to drive back against that direction (never on through the failure).
    A start or goal farther than `reach_m` [m] from every usable path has no route.
    """

    vehicle: Vehicle = "terregator"
    blocked_edges: frozenset[str] = frozenset()
    snap_m: float = 2.0
    reach_m: float = 10.0
    retreat: tuple[float, float] | None = None


@dataclass(frozen=True)
class Leg:
    """One traversal of (part of) an edge, oriented in the direction of travel; world frame [m]."""

    edge_id: str
    mode: str
    path_objects: tuple[str, ...]
    width: float
    coords: tuple[tuple[float, float], ...]
    from_node: str | None
    to_node: str | None

    @property
    def length(self) -> float:
        """Return the leg length [m]."""
        p = np.asarray(self.coords)
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


@dataclass(frozen=True)
class Route:
    """A selected route: legs in order, nodes passed, total cost and length [m], start and goal points."""

    legs: tuple[Leg, ...]
    node_ids: tuple[str, ...]
    cost: float
    start_xy: tuple[float, float]
    goal_xy: tuple[float, float]
    goal_name: str | None = None
    edge_ids: tuple[str, ...] = field(default=())

    @property
    def length(self) -> float:
        """Return the route length [m]."""
        return sum(leg.length for leg in self.legs)

    def polyline(self) -> tuple[tuple[float, float], ...]:
        """Return the route centreline as one polyline (duplicate joints removed)."""
        out: list[tuple[float, float]] = []
        for leg in self.legs:
            for p in leg.coords:
                if not out or math.dist(out[-1], p) > 1e-6:
                    out.append(p)
        if len(out) == 1:
            out.append(out[0])
        return tuple(out)


def edge_forbidden(edge: PathEdge, m: MapData, constraints: StepConstraints, options: RouteOptions) -> str | None:
    """Return why `edge` may not be used under the constraints (None if it may)."""
    if edge.id in options.blocked_edges:
        return "failed before"
    kinds = {m.world.object(o).kind for o in edge.path_objects if m.world.has_object(o)}
    stairs = edge.mode == "climb-stairs" or "stairs" in kinds
    slope = edge.mode == "go-through-slope" or "slope" in kinds
    if stairs and options.vehicle == "navlab":
        return "stairs (impassable for the Navlab)"
    if stairs and constraints.avoid_stairs:
        return "stairs (avoid_stairs)"
    if slope and constraints.avoid_slope:
        return "slope (avoid_slope)"
    for o in edge.path_objects:
        if m.world.has_object(o) and not math.isfinite(m.world.object(o).cost):
            return f"path object {o} is not traversable"
    return None


def edge_cost(edge: PathEdge, m: MapData) -> float:
    """Return the cost of traversing `edge`: length [m] × the highest cost multiplier of its path objects."""
    mult = [m.world.object(o).cost for o in edge.path_objects if m.world.has_object(o)]
    return edge.length * (max(mult) if mult else 1.0)


def _sub_line(coords: np.ndarray, s0: float, s1: float) -> tuple[tuple[float, float], ...]:
    """Return the part of polyline `coords` between arc lengths s0 ≤ s1 [m]."""
    line = shapely.LineString(coords)
    part = shapely.ops.substring(line, s0, s1) if s1 > s0 else shapely.LineString([line.interpolate(s0)] * 2)
    pts = tuple((float(x), float(y)) for x, y in part.coords)
    return pts if len(pts) >= 2 else (pts[0], pts[0])


@dataclass(frozen=True)
class _Attach:
    """A point at arc length s [m] along an edge, where a route end joins the graph."""

    edge: PathEdge
    s: float
    xy: tuple[float, float]


@dataclass(frozen=True)
class _Anchor:
    """Where a route end joins the graph: a node, or points on the nearest usable edges."""

    node: str | None
    xy: tuple[float, float]
    attach: tuple[_Attach, ...] = ()


def _anchor(xy: tuple[float, float], m: MapData, usable: list[PathEdge], snap_m: float, what: str,
            tie_m: float = 1.0, reach_m: float = 10.0) -> _Anchor:
    best_node = min(m.world.nodes, key=lambda n: (math.hypot(n.x - xy[0], n.y - xy[1]), n.id), default=None)
    if best_node is not None and math.hypot(best_node.x - xy[0], best_node.y - xy[1]) <= snap_m:
        return _Anchor(node=best_node.id, xy=(best_node.x, best_node.y))
    p = shapely.Point(xy)
    near = sorted(((shapely.LineString(e.coords).distance(p), e.id, e) for e in usable), key=lambda t: (t[0], t[1]))
    if not near or near[0][0] > reach_m:
        far = f" (nearest {near[0][1]} is {near[0][0]:.1f} m away)" if near else ""
        raise NoRouteError(f"no usable path within {reach_m:.0f} m of the {what} ({xy[0]:.1f}, {xy[1]:.1f}){far}")
    attach = []
    for d, _, e in near:
        if d > near[0][0] + tie_m:
            break
        line = shapely.LineString(e.coords)
        s = float(line.project(p))
        q = line.interpolate(s)
        attach.append(_Attach(edge=e, s=s, xy=(float(q.x), float(q.y))))
    return _Anchor(node=None, xy=attach[0].xy, attach=tuple(attach))


def _overlap_back(a: tuple[tuple[float, float], ...], b: tuple[tuple[float, float], ...], tol: float, step: float = 0.25) -> float:
    """Return how far [m] polyline `b` runs straight back along the end of polyline `a` (within `tol` [m])."""
    la, lb = shapely.LineString(a), shapely.LineString(b)
    reach = min(la.length, lb.length)
    d = 0.0
    for s in np.append(np.arange(step, reach, step), reach):
        if la.interpolate(la.length - s).distance(lb.interpolate(s)) > tol:
            break
        d = float(s)
    return d


def drop_doubling_back(legs: list[Leg], m: MapData, tol: float = 0.3) -> tuple[list[Leg], float]:
    """Return the legs without stretches driven out and straight back, and the cost [m] saved.

    A spur's edge may run along another path to the next intersection (the hall's spur joins the
    south walk half-way between two intersections): the cheapest way over the graph then drives past
    the spur, turns at the intersection and comes back. Cutting the stretch driven twice leaves the
    route the vehicle should take: along the walk to the spur, and into it.
    """
    mult = {e.id: edge_cost(e, m) / max(e.length, 1e-9) for e in m.world.edges}
    out: list[Leg] = []
    saved = 0.0
    for leg in legs:
        cur: Leg | None = leg
        while out and cur is not None:
            prev = out[-1]
            d = _overlap_back(prev.coords, cur.coords, tol)
            if d <= tol:
                break
            out.pop()
            saved += d * (mult.get(prev.edge_id, 1.0) + mult.get(cur.edge_id, 1.0))
            if prev.length - d > 1e-6:
                out.append(replace(prev, coords=_sub_line(np.asarray(prev.coords), 0.0, prev.length - d), to_node=None))
            cur = replace(cur, coords=_sub_line(np.asarray(cur.coords), d, cur.length), from_node=None) if cur.length - d > 1e-6 else None
        if cur is not None:
            out.append(cur)
    return out, saved


def _along(coords: tuple[tuple[float, float], ...], direction: tuple[float, float]) -> float:
    """Return the cosine between a polyline's initial direction and `direction` (0 for degenerate input)."""
    for (x0, y0), (x1, y1) in zip(coords, coords[1:]):
        dx, dy = x1 - x0, y1 - y0
        n = math.hypot(dx, dy) * math.hypot(*direction)
        if n > 1e-9:
            return (dx * direction[0] + dy * direction[1]) / n
    return 0.0


def select_route(m: MapData, start_xy: tuple[float, float], dest: Destination, constraints: StepConstraints,
                 options: RouteOptions = RouteOptions()) -> Route:
    """Return the cheapest route from `start_xy` [m] to `dest` under `constraints`; raise RouteError."""
    usable = [e for e in m.world.edges if edge_forbidden(e, m, constraints, options) is None]
    goal_name: str | None = None
    if dest.place is not None:
        node = m.find_place(dest.place)
        if node is None:
            raise UnknownPlaceError(f"unknown place {dest.place!r} in map {m.name!r}; known places: {', '.join(m.place_names())}")
        goal = _Anchor(node=node.id, xy=(node.x, node.y))
        goal_name = dest.place
    # after a failure, the start (and a goal point) may sit on a blocked edge: attach to it too, but
    # never through the point of failure (the start): only back the way the vehicle came
    anchor_edges = usable
    if options.retreat is not None:
        retreat_ok = RouteOptions(vehicle=options.vehicle, snap_m=options.snap_m)
        anchor_edges = [e for e in m.world.edges if edge_forbidden(e, m, constraints, retreat_ok) is None]
    if dest.place is None:
        assert dest.xy is not None
        goal = _anchor(dest.xy, m, anchor_edges, options.snap_m, "destination", reach_m=options.reach_m)
    start = _anchor(start_xy, m, anchor_edges, options.snap_m, "start", reach_m=options.reach_m)

    adj: dict[str, list[tuple[float, str, Leg]]] = {}

    def link(a: str, b: str, leg: Leg, cost: float) -> None:
        adj.setdefault(a, []).append((cost, b, leg))

    for e in usable:
        c = edge_cost(e, m)
        link(e.from_node, e.to_node, Leg(e.id, e.mode, e.path_objects, e.width, e.coords, e.from_node, e.to_node), c)
        link(e.to_node, e.from_node, Leg(e.id, e.mode, e.path_objects, e.width, tuple(reversed(e.coords)), e.to_node, e.from_node), c)

    def pieces(at: _Attach, name: str) -> list[tuple[float, str, Leg]]:
        """Return (cost, end node, leg from the attach point to that end) for both ends of its edge."""
        e = at.edge
        pts = np.asarray(e.coords)
        mult = edge_cost(e, m) / max(e.length, 1e-9)
        back = tuple(reversed(_sub_line(pts, 0.0, at.s)))
        ahead = _sub_line(pts, at.s, e.length)
        return [(at.s * mult, e.from_node, Leg(e.id, e.mode, e.path_objects, e.width, back, name, e.from_node)),
                ((e.length - at.s) * mult, e.to_node, Leg(e.id, e.mode, e.path_objects, e.width, ahead, name, e.to_node))]

    src = start.node or "@start"
    dst = goal.node or "@goal"
    for at in start.attach:
        for c, n, leg in pieces(at, "@start"):
            if at.edge.id in options.blocked_edges:
                if options.retreat is None or _along(leg.coords, options.retreat) >= 0.0:
                    continue  # a blocked edge only takes the vehicle back the way it came
            link("@start", n, leg, c)
    def crosses_failure(e: PathEdge, s_lo: float, s_hi: float) -> bool:
        """Return whether the stretch [s_lo, s_hi] [m] of blocked edge `e` holds the point of failure."""
        if e.id not in options.blocked_edges:
            return False
        s_fail = float(shapely.LineString(e.coords).project(shapely.Point(start_xy)))
        return options.retreat is None or s_lo - 0.5 <= s_fail <= s_hi + 0.5

    for at in goal.attach:
        for (c, n, leg), (lo, hi) in zip(pieces(at, "@goal"), ((0.0, at.s), (at.s, at.edge.length))):
            if crosses_failure(at.edge, lo, hi):
                continue
            link(n, "@goal", Leg(leg.edge_id, leg.mode, leg.path_objects, leg.width, tuple(reversed(leg.coords)), n, "@goal"), c)
    for a in start.attach:
        for b in goal.attach:
            if a.edge.id != b.edge.id:
                continue
            e = a.edge
            pts = np.asarray(e.coords)
            mult = edge_cost(e, m) / max(e.length, 1e-9)
            coords = _sub_line(pts, a.s, b.s) if b.s >= a.s else tuple(reversed(_sub_line(pts, b.s, a.s)))
            if e.id in options.blocked_edges and (options.retreat is None or _along(coords, options.retreat) >= 0.0):
                continue
            link("@start", "@goal", Leg(e.id, e.mode, e.path_objects, e.width, coords, "@start", "@goal"), abs(b.s - a.s) * mult)

    if src == dst:
        return Route(legs=(), node_ids=(src,), cost=0.0, start_xy=start.xy, goal_xy=goal.xy, goal_name=goal_name)

    dist: dict[str, float] = {src: 0.0}
    prev: dict[str, tuple[str, Leg]] = {}
    heap: list[tuple[float, str]] = [(0.0, src)]
    done: set[str] = set()
    while heap:
        d, u = heapq.heappop(heap)
        if u in done:
            continue
        done.add(u)
        if u == dst:
            break
        for c, v, leg in sorted(adj.get(u, ()), key=lambda t: (t[1], t[2].edge_id)):
            nd = d + c
            if nd < dist.get(v, math.inf) - 1e-12:
                dist[v] = nd
                prev[v] = (u, leg)
                heapq.heappush(heap, (nd, v))
    if dst not in done:
        blocked = [f"{e.id}: {why}" for e in m.world.edges if (why := edge_forbidden(e, m, constraints, options))]
        extra = f" (not usable: {'; '.join(blocked)})" if blocked else ""
        raise NoRouteError(f"no route to {dest.describe()} from ({start_xy[0]:.1f}, {start_xy[1]:.1f}) under the constraints{extra}")
    legs: list[Leg] = []
    nodes: list[str] = [dst]
    v = dst
    while v != src:
        u, leg = prev[v]
        legs.append(leg)
        nodes.append(u)
        v = u
    legs.reverse()
    nodes.reverse()
    legs = [leg for leg in legs if leg.length > 1e-6]
    legs, saved = drop_doubling_back(legs, m)
    passed = {n for leg in legs for n in (leg.from_node, leg.to_node) if n is not None}
    real_nodes = tuple(n for n in nodes if not n.startswith("@") and (n in passed or not legs))
    start_pt = legs[0].coords[0] if legs else start.xy
    goal_pt = legs[-1].coords[-1] if legs else goal.xy
    return Route(legs=tuple(legs), node_ids=real_nodes, cost=dist[dst] - saved, start_xy=start_pt, goal_xy=goal_pt,
                 goal_name=goal_name, edge_ids=tuple(leg.edge_id for leg in legs))
