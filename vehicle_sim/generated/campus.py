"""A generated campus (issue 37): walks through angled, T and Y crossings to a terrace reached by stairs and by a slope beside them.

Like the shipped `campus`, drawn anew from each seed: the walks (`walkways`: 3 m walks on the route
and the foot walk, 2.5 m side walks, 3–4 crossings at 55–125° or Ys, a left and a right turn), the
terrace (`terrace`: 6–8 steps, a 1:10 slope beside the stairs on either side, retaining walls,
terrace walks to the `library`), all in the shipped campus's grey concrete, on lawn; then what
stands beside the walks at the least clearances of `CAMPUS_CLEARANCE` (about a third at exactly
that, the rest up to a little more): trees along every walk (their crowns and shadows reach over
the walks), lamp posts at crossings and along the walks, benches, a hedge, signs at the foot of the
terrace and by the library, buildings at the walks' dead ends (the dormitory behind the start, the
library beyond the destination) and set back beside the route. Another sun and weather per seed.

The mission: the Terregator from the `dorm` to the `library`, keeping right; about half the seeds
add `avoid_stairs`, so the route goes up the slope (the stairs are the cheaper way otherwise). The
actors file: a walker steps onto the first walk in front of the vehicle and stands 20 s; another
crosses the terrace walk. The generator checks the written files (`check.check_written` with the
campus's path kinds and clearances) and that the map's cheapest way to the library climbs the
stairs, and the one avoiding stairs takes the slope. The same seed gives identical files.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely
import yaml
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.errors import SimError
from vehicle_sim.generated.check import check_written
from vehicle_sim.generated.street_network import StreetNetwork
from vehicle_sim.generated.street_world import _frame, _trimmed
from vehicle_sim.generated.terrace import Terrace, TerraceParams, entrance_building, draw_terrace
from vehicle_sim.generated.walkways import CAMPUS_WALKS, draw_walkways
from vehicle_sim.mapgen import map_for
from vehicle_sim.worldfile import (FlatShape, PostShape, PrismShape, SlopeShape, StairsShape, StartPose, Sun, TreeShape, Weather,
                                  World)
from vehicle_sim.worldgen import BRICK, BUFF, CONCRETE, CROWN, GRASS, HEDGE, METAL, RED, STONE, TRUNK, WOOD, WorldBuilder

__all__ = ["CAMPUS_CLEARANCE", "PATH_KINDS", "CampusStyle", "CampusWorld", "CampusWorldError", "generate", "write"]

#: The kinds of the campus's path areas: what standing objects keep clear of and walkers step onto.
PATH_KINDS = ("sidewalk", "intersection", "slope", "stairs")
#: Least distance [m] from a path area to the footprint of each kind beside the walks (about the shipped
#: campus's least: trees 2.7, lamp posts 0.63, benches 0.5, signs 0.92, the hedge 1.5, buildings at a walk's end 3).
CAMPUS_CLEARANCE = {"tree": 2.5, "lamp_post": 0.6, "bench": 0.5, "sign": 0.9, "hedge": 1.5, "building": 3.0}
_EPS = 0.02  # [m] beyond a least clearance, so rounding to mm keeps it
_REACH = CAMPUS_WALKS.legs.reach_m
_SALT = 0xCA4B


class CampusStyle(BaseModel):
    """How a campus is furnished: spacings [m], share at the least clearance, sun [deg] and weather ranges, the mission's vehicle."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    tree_spacing_m: tuple[float, float] = (9.0, 14.0)
    lamp_spacing_m: tuple[float, float] = (24.0, 34.0)
    benches: tuple[int, int] = (2, 4)
    beside_m: tuple[float, float] = (6.0, 12.0)  # set-back of the buildings beside the route from the walk's edge
    at_least_share: float = Field(0.35, ge=0.0, le=1.0)
    avoid_stairs_share: float = Field(0.5, ge=0.0, le=1.0)
    sun_elevation_deg: tuple[float, float] = (25.0, 60.0)
    wet_cover: tuple[float, float] = (0.0, 0.12)
    leaf_cover: tuple[float, float] = (0.0, 0.06)
    vehicle: str = "terregator"


CAMPUS_STYLE = CampusStyle()


@dataclass(frozen=True)
class CampusWorld:
    """One generated campus: the world (truth), the mission and actors documents, the walks, the terrace, the route drawn, what was drawn."""

    name: str
    seed: int
    kind: str
    world: World
    mission: dict
    actors: dict
    network: StreetNetwork
    terrace: Terrace
    route: tuple[str, ...]
    facts: dict


class CampusWorldError(SimError, ValueError):
    """No draw of a campus of this seed passed (the message says what was tried)."""


class _Site:
    """The path areas, the footprints placed so far and the terrace's zone, for the clearance, overlap and level checks."""

    def __init__(self, paths: shapely.Geometry, terrace: Terrace) -> None:
        self.paths = paths
        self.solids: list[shapely.Geometry] = []
        self.zone = terrace.zone
        self.top = terrace.lawn.buffer(-1.0)
        self.height = terrace.height_m

    def level(self, g: shapely.Geometry) -> float | None:
        """Return the ground height [m] under footprint `g`: the terrace's or 0; None where it would straddle the edge."""
        if self.top.contains(g):
            return self.height
        return 0.0 if g.distance(self.zone) >= 1.0 else None

    def fits(self, kind: str, g: shapely.Geometry, gap: float) -> float | None:
        """Return the level of `g` if it keeps its clearance from the paths and `gap` [m] from what stands; else None."""
        if g.distance(self.paths) < CAMPUS_CLEARANCE[kind]:
            return None
        if self.solids and bool(np.any(shapely.dwithin(np.asarray(self.solids, dtype=object), g, gap - 1e-9))):
            return None
        return self.level(g)


def _clearance(rng: np.random.Generator, style: CampusStyle, kind: str, radius: float, most: float) -> float:
    """Return how far [m] from a walk's edge to put an object's centre: its least clearance, or up to `most` more."""
    extra = 0.0 if rng.random() < style.at_least_share else float(rng.uniform(0.0, most))
    return CAMPUS_CLEARANCE[kind] + radius + _EPS + extra


def _coords(g: shapely.Polygon) -> list[tuple[float, float]]:
    return [(float(x), float(y)) for x, y in list(g.exterior.coords)[:-1]]


def _ground(b: WorldBuilder, t: Terrace, net: StreetNetwork) -> dict:
    """Add the lawns, the crossings, the walks, the stairs, the slope, the plaza and the walls; return the nodes by id."""
    h = t.height_m
    pts = np.vstack([s.line for s in net.streets] + [np.asarray(t.lawn.exterior.coords)])
    lo, hi = pts.min(axis=0) - 35.0, pts.max(axis=0) + 35.0
    b.rect("lawn", "grass", float(round(lo[0])), float(round(lo[1])), float(round(hi[0])), float(round(hi[1])), role="none",
           colour=GRASS, cost=4.0, reflectance=0.45)
    b.area("terrace_lawn", "grass", _coords(t.lawn), role="none", colour=GRASS, cost=4.0, shape=FlatShape(z=h), reflectance=0.45)
    slope = SlopeShape(z0=0.0, rise=h, axis_deg=t.axis_deg)
    b.area("terrace_bank", "grass", _coords(t.bank), role="none", colour=GRASS, cost=4.0, shape=slope, reflectance=0.45)
    nodes = {}
    ww = max(t.widths.values())
    for j in net.junctions:
        c = np.array(j.xy)
        ends = []
        for a in j.arms:
            u, n = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
            ends += [c + n * ww / 2, c - n * ww / 2, c + u * _REACH + n * ww / 2, c + u * _REACH - n * ww / 2]
        hull = shapely.MultiPoint(ends).convex_hull
        z = h if j.id == "x_terrace" else 0.0
        b.area(f"int_{j.id}", "intersection", list(hull.exterior.coords)[:-1], role="path", colour=CONCRETE, cost=1.0,
               shape=FlatShape(z=z), reflectance=0.55)
        nodes[j.id] = b.node(j.id, *j.xy, "intersection", obj=f"int_{j.id}")
    for pid, xy in net.places.items():
        nodes[pid] = b.node(pid, *xy, "place", name=pid)
    for st in net.streets:
        w = t.widths[st.id]
        z = h if st.id in t.upper else 0.0
        walk = b.strip(f"walk_{st.id}", "sidewalk", [tuple(p) for p in _trimmed(net, st, _REACH)], w, role="path", colour=CONCRETE,
                       cost=1.0, shape=FlatShape(z=z), reflectance=0.55)
        b.edge(f"e_{st.id}", nodes[st.a], nodes[st.b], mode="follow-road", objs=(walk.id,), width=w, via=[tuple(p) for p in st.line[1:-1]])
    b.area("walk_approach", "sidewalk", _coords(t.approach), role="path", colour=CONCRETE, cost=1.0, reflectance=0.55)
    b.edge("e_approach", nodes["foot"], nodes["stairs_bottom"], mode="follow-road", objs=("walk_approach",), width=ww)
    b.area("stairs_main", "stairs", _coords(t.stairs), role="path", colour=CONCRETE, cost=1.5,
           shape=StairsShape(z0=0.0, rise=h, axis_deg=t.axis_deg, step_rise=0.15), name="main stairs", reflectance=0.55)
    b.area("slope_ramp", "slope", _coords(t.ramp), role="path", colour=CONCRETE, cost=1.2, shape=slope, name="ramp", reflectance=0.55)
    b.area("plaza", "sidewalk", _coords(t.plaza), role="path", colour=CONCRETE, cost=1.0, shape=FlatShape(z=h), name="plaza",
           reflectance=0.55)
    b.edge("e_stairs", nodes["stairs_bottom"], nodes["stairs_top"], mode="climb-stairs", objs=("stairs_main", "plaza"),
           width=_width_across(t.stairs, t.axis_deg))
    b.edge("e_slope", nodes["slope_bottom"], nodes["stairs_top"], mode="go-through-slope", objs=("slope_ramp", "plaza"),
           width=_width_across(t.ramp, t.axis_deg), via=t.slope_via)
    for k, wall in enumerate(t.walls):
        b.area(f"wall_{k}", "wall", _coords(wall), role="obstacle", colour=STONE, shape=PrismShape(height=round(h + 0.4, 3)), reflectance=0.5)
    return nodes


def _width_across(g: shapely.Polygon, axis_deg: float) -> float:
    """Return a rectangle's extent [m] across the axis `axis_deg` [deg] (a stairs' or ramp's width)."""
    a = math.radians(axis_deg)
    across = np.asarray(g.exterior.coords) @ np.array([-math.sin(a), math.cos(a)])
    return round(float(across.max() - across.min()), 3)


def _buildings(b: WorldBuilder, t: Terrace, net: StreetNetwork, site: _Site, rng: np.random.Generator, style: CampusStyle,
               facts: dict) -> bool:
    """Add the dormitory behind the start, the terrace's buildings, a building at each lower dead end and beside the route where they fit."""
    h = t.height_m
    dorm = entrance_building(np.array(net.places["dorm"]), net.start_yaw + math.pi, float(rng.uniform(26.0, 34.0)), float(rng.uniform(14.0, 18.0)))
    if site.fits("building", dorm, 2.0) != 0.0:
        return False
    b.area("b_dorm", "building", _coords(dorm), role="landmark", colour=BUFF, shape=PrismShape(height=12.0), name="Dormitory", reflectance=0.6)
    site.solids.append(dorm)
    for pid, g in t.buildings.items():
        big = pid == "library"
        if site.fits("building", g, 2.0) != h:
            if big:
                return False
            continue
        b.area(f"b_{pid}", "building", _coords(g), role="landmark", colour=BRICK if big else (BUFF, STONE)[len(site.solids) % 2],
               shape=PrismShape(height=round(float(rng.uniform(10.0, 15.0)), 2), z0=h), name="Library" if big else None, reflectance=0.6)
        site.solids.append(g)
    upper = {s.b for s in net.streets if s.id in t.upper}
    for st in net.streets:
        if st.b in net.places and st.b not in upper and st.b not in ("stairs_top",) and not any(s.a == st.b for s in net.streets):
            d = st.line[-1] - st.line[-2]
            g = entrance_building(st.line[-1], math.atan2(d[1], d[0]), float(rng.uniform(14.0, 26.0)), float(rng.uniform(10.0, 18.0)))
            if site.fits("building", g, 2.0) == 0.0 and g.distance(site.zone) >= 2.0:
                b.area(f"b_{st.b}", "building", _coords(g), role="landmark", colour=(BRICK, BUFF, STONE)[len(site.solids) % 3],
                       shape=PrismShape(height=round(float(rng.uniform(8.0, 16.0)), 2)), reflectance=0.6)
                site.solids.append(g)
    for st in net.streets:
        if not st.on_route or st.id in t.upper or "foot" in (st.a, st.b):
            continue
        line = shapely.LineString(_trimmed(net, st, _REACH))
        for k, s in enumerate(np.arange(8.0, line.length - 8.0, 40.0)):
            c, u, n = _frame(line, float(s) + float(rng.uniform(-3.0, 3.0)))
            side = 1.0 if rng.random() < 0.5 else -1.0
            w, d, back = float(rng.uniform(18.0, 30.0)), float(rng.uniform(12.0, 20.0)), float(rng.uniform(*style.beside_m))
            hc = c + n * side * (t.widths[st.id] / 2 + back + d / 2)
            g = shapely.Polygon([tuple(np.round(hc + u * su * w / 2 + n * sn * d / 2, 3)) for su, sn in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
            if site.fits("building", g, 3.0) == 0.0 and g.distance(site.zone) >= 3.0:
                b.area(f"b_{st.id}_{k}", "building", _coords(g), role="landmark", colour=(BRICK, BUFF, STONE)[len(site.solids) % 3],
                       shape=PrismShape(height=round(float(rng.uniform(8.0, 16.0)), 2)), reflectance=0.6)
                site.solids.append(g)
    facts["buildings"] = sum(o.kind == "building" for o in b.objects)
    return True


def _walk_frames(net: StreetNetwork, t: Terrace) -> list[tuple[str, shapely.LineString, float]]:
    """Return every walk's id, its centreline between crossings and its width [m], the route's first."""
    out = [(st.id, shapely.LineString(_trimmed(net, st, _REACH)), t.widths[st.id]) for st in net.streets]
    return sorted(out, key=lambda x: not next(s for s in net.streets if s.id == x[0]).on_route)


def _trees(b: WorldBuilder, net: StreetNetwork, t: Terrace, site: _Site, rng: np.random.Generator, style: CampusStyle, facts: dict) -> None:
    """Add trees along both sides of every walk, `tree_spacing_m` apart, on a side drawn per tree; what does not fit is left out."""
    for sid, line, w in _walk_frames(net, t):
        k = 0
        s = float(rng.uniform(2.0, 6.0))
        while s < line.length - 2.0:
            c, _, n = _frame(line, s)
            side = 1.0 if rng.random() < 0.5 else -1.0
            height, crown = float(rng.uniform(6.0, 10.0)), float(rng.uniform(1.8, 3.2))  # as `WorldBuilder.tree` draws them
            trunk = round(float(rng.uniform(0.15, 0.3)), 3)
            p = c + n * side * (w / 2 + _clearance(rng, style, "tree", trunk, 2.0))
            g = shapely.Point(p).buffer(trunk)
            z = site.fits("tree", g, 0.8)
            if z is not None and all(g.distance(o) >= crown for o in site.solids if o.area > 20.0):
                shape = TreeShape(trunk_radius=trunk, crown_radius=round(crown, 2), height=round(height, 2), crown_base=round(height * 0.4, 2), z0=z)
                b.round_obj(f"tree_{sid}_{k:02d}", "tree", float(p[0]), float(p[1]), trunk, role="obstacle", colour=TRUNK, shape=shape,
                            reflectance=0.35, crown=CROWN)
                site.solids.append(g)
                facts["trees"] += 1
            k += 1
            s += float(rng.uniform(*style.tree_spacing_m))


def _post(b: WorldBuilder, site: _Site, oid: str, kind: str, p: np.ndarray, radius: float, height: float, colour, facts: dict,
          name: str | None = None) -> bool:
    """Add a post (lamp post, sign) of `radius` [m] at `p` if it fits; return whether it did."""
    g = shapely.Point(p).buffer(radius)
    z = site.fits(kind, g, 0.8)
    if z is None:
        return False
    b.round_obj(oid, kind, float(p[0]), float(p[1]), radius, role="landmark", colour=colour, shape=PostShape(height=height, z0=z),
                name=name, reflectance=0.8 if kind == "sign" else 0.7)
    site.solids.append(g)
    facts[kind + "s"] = facts.get(kind + "s", 0) + 1
    return True


def _furniture(b: WorldBuilder, net: StreetNetwork, t: Terrace, site: _Site, rng: np.random.Generator, style: CampusStyle,
               facts: dict) -> None:
    """Add the signs (foot of the terrace, library), lamp posts at crossings and along walks, benches and a hedge at their clearances."""
    into = next(s for s in net.streets if s.b == "foot")
    line = shapely.LineString(_trimmed(net, into, _REACH))
    c, _, n = _frame(line, line.length - 1.5)
    _post(b, site, "sign_terrace", "sign", c - n * (t.widths[into.id] / 2 + _clearance(rng, style, "sign", 0.08, 0.6)), 0.08, 2.2, RED,
          facts, "terrace sign")
    lib = next(s for s in net.streets if s.b == "library")
    line = shapely.LineString(lib.line)
    c, _, n = _frame(line, line.length - 3.0)
    _post(b, site, "sign_library", "sign", c - n * (t.widths[lib.id] / 2 + _clearance(rng, style, "sign", 0.08, 0.6)), 0.08, 2.2, RED,
          facts, "library sign")
    for j in net.junctions:
        a = j.arms[int(rng.integers(0, len(j.arms)))]
        u, n = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        side = 1.0 if rng.random() < 0.5 else -1.0
        half = max(t.widths.values()) / 2
        corner = np.array(j.xy) + u * (_REACH + 1.0) + n * side * (half + _clearance(rng, style, "lamp_post", 0.12, 0.8))
        _post(b, site, f"lamp_{j.id}", "lamp_post", corner, 0.12, 4.0, METAL, facts)
    benches = int(rng.integers(style.benches[0], style.benches[1] + 1))
    hedge = False
    for sid, line, w in _walk_frames(net, t):
        k = 0
        for s in np.arange(float(rng.uniform(6.0, 14.0)), line.length - 6.0, float(rng.uniform(*style.lamp_spacing_m))):
            c, _, n = _frame(line, float(s))
            side = 1.0 if k % 2 == 0 else -1.0
            _post(b, site, f"lamp_{sid}_{k}", "lamp_post", c + n * side * (w / 2 + _clearance(rng, style, "lamp_post", 0.12, 0.8)), 0.12, 4.0,
                  METAL, facts)
            k += 1
        if line.length > 14.0 and facts["benches"] < benches and rng.random() < 0.6:
            c, u, n = _frame(line, float(rng.uniform(5.0, line.length - 5.0)))
            side = 1.0 if rng.random() < 0.5 else -1.0
            mid = c + n * side * (w / 2 + _clearance(rng, style, "bench", 0.3, 0.5))
            g = shapely.Polygon([tuple(np.round(mid + u * su * 1.0 + n * sn * 0.3, 3)) for su, sn in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
            z = site.fits("bench", g, 0.8)
            if z is not None:
                b.area(f"bench_{sid}", "bench", _coords(g), role="obstacle", colour=WOOD, shape=PrismShape(height=0.45, z0=z), reflectance=0.4)
                site.solids.append(g)
                facts["benches"] += 1
        if not hedge and line.length > 30.0 and sid not in t.upper:
            s0 = float(rng.uniform(4.0, line.length - 24.0))
            a, _, n = _frame(line, s0)
            e, _, _ = _frame(line, s0 + float(rng.uniform(12.0, 20.0)))
            side = 1.0 if rng.random() < 0.5 else -1.0
            off = n * side * (w / 2 + _clearance(rng, style, "hedge", 0.5, 1.0))
            g = shapely.LineString([a + off, e + off]).buffer(0.5, cap_style="flat")
            if site.fits("hedge", g, 1.0) == 0.0:
                b.strip("hedge", "hedge", [tuple(np.round(a + off, 3)), tuple(np.round(e + off, 3))], 1.0, role="obstacle", colour=HEDGE,
                        shape=PrismShape(height=1.0), reflectance=0.3)
                site.solids.append(g)
                hedge = True
    facts["hedges"] = int(hedge)


def _describe(net: StreetNetwork, t: Terrace, avoid_stairs: bool, route: tuple[str, ...], lengths: dict) -> dict:
    return {
        "crossings": [{"node": j.id, "angle_deg": j.angle_deg, "turn": j.turn, "kind": j.kind} for j in net.junctions if j.id != "foot"],
        "bends": [{"radius_m": round(r, 1), "turn_deg": round(d, 1)} for r, d in net.bends],
        "terrace": {"height_m": t.height_m, "steps": t.steps, "slope_side": "left" if t.side > 0 else "right"},
        "avoid_stairs": avoid_stairs,
        "route": list(route),
        "route_m": round(sum(lengths[frozenset(p)] for p in zip(route[:-1], route[1:])), 1),
    }


def _mission(name: str, seed: int, style: CampusStyle, net: StreetNetwork, facts: dict) -> dict:
    turns = ", ".join(f"{j['turn']} at {j['node']} ({j['kind']}, {j['angle_deg']:.0f}°)" for j in facts["crossings"])
    way = "the slope (avoiding the stairs)" if facts["avoid_stairs"] else "the stairs"
    constraints: list = ["keep_right", "avoid_stairs"] if facts["avoid_stairs"] else ["keep_right"]
    return {
        "mission": name,
        "description": f"campus seed {seed}: from the dorm to the library on the terrace by {way}, {facts['route_m']:.0f} m: {turns}",
        "world": name, "vehicle": style.vehicle,
        "steps": [{"name": f"to the library by {way}", "destination": "library", "constraints": constraints, "trigger": "stop"}],
    }


def _actors(net: StreetNetwork, t: Terrace, rng: np.random.Generator) -> dict:
    """Return the actors document: a walker stepping onto the first walk and standing 20 s, another crossing the terrace walk."""

    def wp(p: np.ndarray, **kw) -> dict:
        return {"x": round(float(p[0]), 3), "y": round(float(p[1]), 3), **kw}

    first = next(s for s in net.streets if s.a == "dorm")
    w = t.widths[first.id]
    line = shapely.LineString(_trimmed(net, first, _REACH))
    c, _, n = _frame(line, line.length * float(rng.uniform(0.45, 0.65)))
    walker = {"id": "walker", "kind": "pedestrian", "speed": 1.2, "trigger_distance": 20.0,
              "path": [wp(c - n * (w / 2 + 1.5)), wp(c - n * 0.4, dwell=20.0), wp(c + n * (w / 2 + 2.0))]}
    up = next(s for s in net.streets if s.id == "top_terrace")
    line = shapely.LineString(up.line)
    c, _, n = _frame(line, line.length * float(rng.uniform(0.4, 0.6)))
    side = 1.0 if rng.random() < 0.5 else -1.0
    crosser = {"id": "crosser", "kind": "pedestrian", "speed": 1.3, "trigger_distance": 15.0,
               "path": [wp(c + n * side * 4.0), wp(c), wp(c - n * side * 4.0)]}
    return {"actors": [walker, crosser]}


def build_campus_world(name: str, seed: int, t: Terrace, rng: np.random.Generator, style: CampusStyle = CAMPUS_STYLE) -> CampusWorld | None:
    """Build the campus on the walks and terrace `t`; None when the dormitory or the library cannot stand (draw again)."""
    net = t.network
    b = WorldBuilder(name)
    _ground(b, t, net)
    site = _Site(shapely.union_all([o.footprint for o in b.objects if o.kind in PATH_KINDS]), t)
    facts: dict = {"trees": 0, "benches": 0, "signs": 0, "lamp_posts": 0}
    if not _buildings(b, t, net, site, rng, style, facts):
        return None
    _furniture(b, net, t, site, rng, style, facts)
    _trees(b, net, t, site, rng, style, facts)
    if facts["signs"] == 0 or facts["lamp_posts"] < 3 or facts["trees"] < 10:
        return None
    avoid_stairs = bool(rng.random() < style.avoid_stairs_share)
    route = t.slope_route if avoid_stairs else t.stairs_route
    sun = Sun(azimuth_deg=round(float(rng.uniform(0.0, 360.0)), 1), elevation_deg=round(float(rng.uniform(*style.sun_elevation_deg)), 1))
    weather = Weather(wet_cover=round(float(rng.uniform(*style.wet_cover)), 3), leaf_cover=round(float(rng.uniform(*style.leaf_cover)), 3),
                      period_s=round(float(rng.uniform(240.0, 600.0))))
    start = StartPose(x=0.0, y=0.0, yaw_deg=round(math.degrees(net.start_yaw), 3), node="dorm")
    world = b.world(sun=sun, start=start, weather=weather)
    lengths = {frozenset((e.from_node, e.to_node)): e.length for e in world.edges}
    facts.update(_describe(net, t, avoid_stairs, route, lengths))
    mission = _mission(name, seed, style, net, facts)
    return CampusWorld(name, seed, "campus", world, mission, _actors(net, t, rng), net, t, route, facts)


def generate(seed: int, *, name: str | None = None, attempts: int = 60) -> CampusWorld:
    """Return the campus of `seed`: draw walks and a terrace from (`seed`, attempt) until they are apart and furnishable."""
    for attempt in range(attempts):
        rng = np.random.default_rng([seed, attempt, _SALT])
        net = draw_walkways(rng, CAMPUS_WALKS)
        if net is None:
            continue
        t = draw_terrace(rng, net, CAMPUS_WALKS.legs, TerraceParams())
        if t is None:
            continue
        out = build_campus_world(name or f"campus_{seed}", seed, t, rng)
        if out is not None:
            return out
    raise CampusWorldError(f"campus seed {seed}: no walks and terrace of {attempts} draws were apart and furnishable")


def write(cw: CampusWorld, out: str | Path) -> list[Path]:
    """Write the world, its map (the shipped maps' error, drawn from the seed), the mission and the actors; check them; return the paths.

    Besides `check.check_written` (clearances from the walks, the mission's places, its route under its
    constraints, the walkers): on the map the cheapest way to the library climbs the stairs and the
    cheapest way avoiding stairs goes up the slope, so both join the terrace to the walks below.
    """
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    n = cw.name
    paths = [d / f"{n}.world.geojson", d / f"{n}.map.geojson", d / f"{n}.yaml", d / f"{n}.actors.yaml"]
    cw.world.save(paths[0])
    map_for(cw.world, 1.0, cw.seed).save(paths[1])
    cmd = f"sidewalk worldgen campus --seed {cw.seed}" + ("" if n == f"campus_{cw.seed}" else f" --name {n}")
    head = f"# generated by `{cmd}`\n"
    paths[2].write_text(head + yaml.safe_dump(cw.mission, sort_keys=False, allow_unicode=True))
    paths[3].write_text(head + "# a walker steps onto the first walk and stands 20 s; another crosses the terrace walk\n"
                        + yaml.safe_dump(cw.actors, sort_keys=False))
    t = cw.terrace
    check_written(paths[0], paths[1], paths[2], paths[3], cw.route, path_kinds=PATH_KINDS, clearance=CAMPUS_CLEARANCE,
                  ways=((t.stairs_route, False), (t.slope_route, True)))
    return paths
