"""The ROUTE SELECTOR's decomposition: cut a route into route segments with one navigation mode each.

Edges give follow-road, go-through-slope and climb-stairs segments; where the route passes an
intersection node, the stretch around it (the intersection area plus an approach that lets the
vehicle turn: its minimum turning radius) becomes a turn-at-intersection or go-through-intersection
segment, by the heading change across it. For a vehicle with a turning radius, a turn's centreline
rounds the corner with an arc it can drive (`fillet_radius`): the PILOT's goals along the segment
then have headings a forward-only vehicle can reach one after the other. Consecutive pieces with
the same mode and the same path objects merge. World frame, metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from modules.map_navigator.mapdata import MapData
from modules.map_navigator.route import Leg, Route, _sub_line
from wire.se2 import wrap_angle

__all__ = ["SegmentPlan", "SegmentOptions", "segment_route", "heading_change", "fillet_radius", "fillet_corner", "TURN_THRESHOLD_RAD"]

#: A heading change across an intersection above this is a turn [rad] (30°).
TURN_THRESHOLD_RAD = math.radians(30.0)


@dataclass(frozen=True)
class SegmentOptions:
    """Decomposition settings: approach beyond the intersection area [m], vehicle turning radius [m].

    `turn_settle_m` [m] is the straight run a turn segment keeps on either side of its arc (vehicles
    with a turning radius only): room to line up before the arc and to settle into the lane after it.
    """

    approach_m: float = 1.0
    turn_radius_m: float = 0.0
    min_piece_m: float = 0.5
    turn_settle_m: float = 4.0


@dataclass(frozen=True)
class SegmentPlan:
    """One route segment before description: mode, centreline (direction of travel), path objects, width [m]."""

    mode: str
    coords: tuple[tuple[float, float], ...]
    path_objects: tuple[str, ...]
    width: float
    edge_ids: tuple[str, ...]
    node_id: str | None = None

    @property
    def length(self) -> float:
        """Return the centreline length [m]."""
        p = np.asarray(self.coords)
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def _direction(coords: tuple[tuple[float, float], ...], at_end: bool) -> float:
    """Return the heading [rad] of a polyline at its start or end (skipping zero-length pieces)."""
    pts = list(coords) if at_end else list(reversed(coords))
    for i in range(len(pts) - 1, 0, -1):
        (x0, y0), (x1, y1) = pts[i - 1], pts[i]
        if math.hypot(x1 - x0, y1 - y0) > 1e-6:
            return math.atan2(y1 - y0, x1 - x0) if at_end else math.atan2(y0 - y1, x0 - x1)
    return 0.0


def heading_change(before: tuple[tuple[float, float], ...], after: tuple[tuple[float, float], ...]) -> float:
    """Return the signed heading change [rad] in [-π, π) from the end of `before` to the start of `after`."""
    d = _direction(after, at_end=False) - _direction(before, at_end=True)
    return wrap_angle(d)


def fillet_radius(turn_radius: float, width: float) -> float:
    """Return the radius [m] of a turn's centreline arc: the turning radius plus the keep-right/left offset (width/4).

    Offset by a quarter of the path width to either side (the MAP NAVIGATOR's keep offset), the
    arc's radius stays at least `turn_radius` [m]. A vehicle that turns in place (0) gets a corner.
    """
    return turn_radius + width / 4.0 if turn_radius > 0.0 else 0.0


def fillet_corner(coords: tuple[tuple[float, float], ...], s_corner: float, tangent: float, step: float = 0.5) -> tuple[tuple[float, float], ...]:
    """Return `coords` with the corner at arc length `s_corner` [m] rounded by an arc starting `tangent` [m] before it.

    The arc leaves the incoming piece tangentially `tangent` [m] before the corner and joins the
    outgoing piece's line tangentially (about `tangent` [m] after the corner when the pieces are
    straight); its radius follows from those two tangencies.
    """
    pts = np.asarray(coords, dtype=np.float64)
    L = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    if tangent <= 1e-6 or s_corner - tangent < -1e-9 or s_corner + tangent > L + 1e-9:
        return coords
    before = _sub_line(pts, 0.0, max(0.0, s_corner - tangent))
    after = _sub_line(pts, min(L, s_corner + tangent), L)
    h_a = _direction(before, at_end=True) if math.dist(before[0], before[-1]) > 1e-6 else _direction(_sub_line(pts, 0.0, s_corner), True)
    h_b = _direction(after, at_end=False) if math.dist(after[0], after[-1]) > 1e-6 else _direction(_sub_line(pts, s_corner, L), False)
    theta = wrap_angle(h_b - h_a)
    if abs(theta) < 1e-3:
        return coords
    side = 1.0 if theta > 0 else -1.0  # centre on the left for a left turn
    a, b = np.asarray(before[-1]), np.asarray(after[0])
    n_a = side * np.array([-math.sin(h_a), math.cos(h_a)])  # towards the centre
    m_b = side * np.array([-math.sin(h_b), math.cos(h_b)])  # from the outgoing line towards the centre
    u_b = np.array([math.cos(h_b), math.sin(h_b)])
    radius = float((a - b) @ m_b) / (1.0 - float(n_a @ m_b))
    if not (0.5 * tangent / math.tan(abs(theta) / 2.0) < radius < 2.0 * tangent / math.tan(abs(theta) / 2.0)):
        return coords  # the pieces are too far from straight to round this corner
    c = a + radius * n_a
    e = c - radius * m_b  # where the arc meets the outgoing line
    a0 = math.atan2(a[1] - c[1], a[0] - c[0])
    n = max(2, int(math.ceil(abs(theta) * radius / step)))
    arc = tuple((float(c[0] + radius * math.cos(a0 + theta * k / n)), float(c[1] + radius * math.sin(a0 + theta * k / n)))
                for k in range(1, n)) + ((float(e[0]), float(e[1])),)
    past = float((e - b) @ u_b)  # the arc may end a little past the outgoing piece's start
    la = float(np.linalg.norm(np.diff(np.asarray(after), axis=0), axis=1).sum())
    if past > 0.0:
        after = _sub_line(np.asarray(after), min(past, la), la)
    return _join(_join(before, arc), after)


def _join(a: tuple[tuple[float, float], ...], b: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    out = list(a)
    for p in b:
        if not out or math.dist(out[-1], p) > 1e-6:
            out.append(p)
    if len(out) == 1:
        out.append(out[0])
    return tuple(out)


def _carve(m: MapData, node_id: str, leg: Leg, at_end: bool, opts: SegmentOptions, tangent: float = 0.0) -> float:
    """Return how far from the node along `leg` [m] the intersection segment reaches (past a fillet's `tangent` [m])."""
    area = m.intersection_area(node_id)
    line = shapely.LineString(leg.coords if not at_end else tuple(reversed(leg.coords)))
    if area is not None:
        inside = 0.0
        b = area.footprint.boundary.intersection(line)
        if not b.is_empty:
            pts = [b] if b.geom_type == "Point" else list(getattr(b, "geoms", [b]))
            inside = min(float(line.project(p)) for p in pts if p.geom_type == "Point") if any(p.geom_type == "Point" for p in pts) else 0.0
        if inside <= 0.0:
            inside = leg.width / 2.0
    else:
        inside = leg.width / 2.0
    reach = max(inside + opts.approach_m, opts.turn_radius_m + opts.approach_m)
    if tangent > 0.0:
        reach = max(reach, tangent + opts.approach_m + opts.turn_settle_m)
    return min(reach, 0.45 * leg.length)


def segment_route(route: Route, m: MapData, opts: SegmentOptions = SegmentOptions()) -> list[SegmentPlan]:
    """Return the route's segments in driving order, one navigation mode each."""
    legs = route.legs
    if not legs:
        return []
    cut_head = [0.0] * len(legs)
    cut_tail = [0.0] * len(legs)
    joints: dict[int, str] = {}  # leg index i → intersection node between legs i and i+1
    tangents: dict[int, float] = {}  # leg index i → fillet tangent length at that node [m]
    for i in range(len(legs) - 1):
        node = legs[i].to_node
        if node is None or node.startswith("@"):
            continue
        if m.world.node(node).node_kind != "intersection":
            continue
        joints[i] = node
        theta = abs(heading_change(legs[i].coords, legs[i + 1].coords))
        radius = fillet_radius(opts.turn_radius_m, max(legs[i].width, legs[i + 1].width))
        tangent = radius * math.tan(min(theta, math.radians(150.0)) / 2.0) if theta > TURN_THRESHOLD_RAD and radius > 0.0 else 0.0
        cut_tail[i] = _carve(m, node, legs[i], True, opts, tangent)
        cut_head[i + 1] = _carve(m, node, legs[i + 1], False, opts, tangent)
        tangents[i] = min(tangent, cut_tail[i], cut_head[i + 1])

    pieces: list[SegmentPlan] = []
    for i, leg in enumerate(legs):
        L = leg.length
        s0, s1 = cut_head[i], L - cut_tail[i]
        pts = np.asarray(leg.coords)
        if s1 - s0 >= opts.min_piece_m or (s0 == 0.0 and s1 == L):
            pieces.append(SegmentPlan(leg.mode, _sub_line(pts, s0, s1), leg.path_objects, leg.width, (leg.edge_id,)))
        elif pieces:  # a sliver between two intersections: fold it into the previous piece
            prev = pieces[-1]
            pieces[-1] = SegmentPlan(prev.mode, _join(prev.coords, _sub_line(pts, s0, max(s0, s1))), prev.path_objects,
                                     prev.width, prev.edge_ids + (leg.edge_id,), prev.node_id)
        if i in joints:
            nxt = legs[i + 1]
            tail = _sub_line(pts, L - cut_tail[i], L)
            head = _sub_line(np.asarray(nxt.coords), 0.0, cut_head[i + 1])
            turn = abs(heading_change(leg.coords, nxt.coords)) > TURN_THRESHOLD_RAD
            area = m.intersection_area(joints[i])
            objs = (area.id,) if area is not None else tuple(dict.fromkeys(leg.path_objects + nxt.path_objects))
            coords = _join(tail, head)
            if turn and tangents.get(i, 0.0) > 0.0:
                coords = fillet_corner(coords, cut_tail[i], tangents[i])
            pieces.append(SegmentPlan("turn-at-intersection" if turn else "go-through-intersection", coords, objs,
                                      max(leg.width, nxt.width), (leg.edge_id, nxt.edge_id), joints[i]))

    merged: list[SegmentPlan] = []
    for p in pieces:
        if merged and merged[-1].mode == p.mode and merged[-1].path_objects == p.path_objects and p.node_id is None and merged[-1].node_id is None:
            q = merged[-1]
            merged[-1] = SegmentPlan(q.mode, _join(q.coords, p.coords), q.path_objects, min(q.width, p.width),
                                     tuple(dict.fromkeys(q.edge_ids + p.edge_ids)))
        else:
            merged.append(p)
    return merged
