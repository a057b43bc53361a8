"""A street world on a drawn network: roads, crossings, lots, roadside objects, the destination, a delivery mission, actors.

Shared by the `suburb` and `marked-road` kinds (`StreetStyle` says how they differ). Every street
is an asphalt road object of the style's width with its path-graph edge; every crossing an
intersection area (the convex hull of its streets' ends, so any crossing angle is covered). Along
both sides of every street lots follow one another (the first a few metres from a crossing): a
driveway (concrete, asphalt, gravel or pavers), a house at least 8 m back, a mailbox and trees.
Roadside objects stand at the least clearance `worldgen.ROADSIDE_CLEARANCE` allows or a little
more; whatever a lot cannot fit (a house across another street, a tree on a driveway) is left out
of that lot. Stop signs and hydrants stand at crossing corners. The destination is the delivery
mailbox beside the `mailbox` place, on the side the draw chose, with its driveway and house.

The actors file puts a walker into the route's lane on its first street (it steps in when the
vehicle is 30 m away and stands 30 s) and a car parked in the route's lane further on (it pulls
away 30 s after the vehicle came within 25 m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import shapely
import shapely.ops
import yaml
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.errors import SimError
from vehicle_sim.generated.check import check_written
from vehicle_sim.generated.street_network import NetworkParams, Street, StreetNetwork, draw_network
from vehicle_sim.mapgen import map_for
from vehicle_sim.worldfile import Marking, PostShape, PrismShape, StartPose, Sun, Weather, World, WorldObject
from vehicle_sim.worldgen import ASPHALT, DRIVEWAYS, GRASS, HEDGE, MAILBOX, RED, ROADSIDE_CLEARANCE, SIDING, WorldBuilder

__all__ = ["StreetStyle", "StreetWorld", "StreetWorldError", "build_street_world", "generate_street_world", "write_street_world", "MarkingsFor", "EXTRA_ROAD", "DRIVEWAY_NAMES"]

#: Markings of one street: (the network, the street, its centreline trimmed at crossings (K, 2) [m]) -> the painted stripes.
MarkingsFor = Callable[[StreetNetwork, Street, np.ndarray], tuple[Marking, ...]]
#: Extra road areas of a style (e.g. a turn lane): (network, builder, trimmed centreline by street id) -> nothing (it adds them).
EXTRA_ROAD = Callable[[StreetNetwork, WorldBuilder, dict[str, np.ndarray]], None]

#: What each of `worldgen.DRIVEWAYS` is.
DRIVEWAY_NAMES = ("concrete", "asphalt", "gravel", "pavers")
_EPS = 0.02  # [m] beyond a least clearance, so rounding to mm keeps it


class StreetStyle(BaseModel):
    """How a street world looks: road width [m], lots and trees, the sun and weather ranges, the mission's speed limit [m/s]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    road_width_m: float = 6.0
    lot_m: tuple[float, float] = (26.0, 34.0)  # a lot's frontage
    lot_share: float = Field(1.0, ge=0.0, le=1.0)  # share of lots with a house
    trees_per_lot: tuple[int, int] = (1, 2)
    tree_row_m: float | None = None  # a row of roadside trees this far apart (marked roads), else trees by lot
    at_least_share: float = Field(0.35, ge=0.0, le=1.0)  # share of roadside objects at exactly the least clearance
    sun_elevation_deg: tuple[float, float] = (25.0, 60.0)
    wet_cover: tuple[float, float] = (0.0, 0.15)
    leaf_cover: tuple[float, float] = (0.0, 0.08)
    speed_limit: float = 5.0
    vehicle: str = "navlab"
    kind: str = "suburb"  # the worldgen kind (for the files' comments)


@dataclass(frozen=True)
class StreetWorld:
    """One generated street world: the world (truth), the mission and actors documents, the network and what was drawn."""

    name: str
    seed: int
    kind: str
    world: World
    mission: dict
    actors: dict
    network: StreetNetwork
    facts: dict


def _frame(line: shapely.LineString, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the point at arc length `s` [m] of `line`, its unit tangent and its unit left normal."""
    a = line.interpolate(max(0.0, s - 0.5))
    b = line.interpolate(min(line.length, s + 0.5))
    u = np.array([b.x - a.x, b.y - a.y])
    u /= np.linalg.norm(u)
    p = line.interpolate(s)
    return np.array([p.x, p.y]), u, np.array([-u[1], u[0]])


def _trimmed(net: StreetNetwork, st: Street, reach: float) -> np.ndarray:
    """Return a street's centreline (K, 2) [m] without the parts inside the crossings at its ends."""
    line = shapely.LineString(st.line)
    crossings = {j.id for j in net.junctions}
    t0 = reach if st.a in crossings else 0.0
    t1 = reach if st.b in crossings else 0.0
    part = shapely.ops.substring(line, t0, line.length - t1)
    return np.round(np.asarray(part.coords, float), 3)


class _Site:
    """The footprints placed so far, and the road areas, for the lot and roadside checks."""

    def __init__(self, roads: shapely.Geometry) -> None:
        self.roads = roads
        self.solids: list[shapely.Geometry] = []

    def free(self, g: shapely.Geometry, gap: float) -> bool:
        return not bool(np.any(shapely.dwithin(np.asarray(self.solids, dtype=object), g, gap - 1e-9))) if self.solids else True

    def roadside_ok(self, kind: str, g: shapely.Geometry) -> bool:
        return g.distance(self.roads) >= ROADSIDE_CLEARANCE[kind] and self.free(g, 0.8)


def _clearance(rng: np.random.Generator, style: StreetStyle, kind: str, radius: float, most: float) -> float:
    """Return how far [m] from the road's edge to put a roadside object's centre: its least clearance, or up to `most` more."""
    extra = 0.0 if rng.random() < style.at_least_share else float(rng.uniform(0.0, most))
    return ROADSIDE_CLEARANCE[kind] + radius + _EPS + extra


def build_street_world(name: str, seed: int, net: StreetNetwork, rng: np.random.Generator, style: StreetStyle,
                       reach: float, markings_for: MarkingsFor | None = None, extra_road: EXTRA_ROAD | None = None
                       ) -> StreetWorld | None:
    """Build the world on `net`; None when the destination cannot be furnished (draw again)."""
    rw = style.road_width_m
    b = WorldBuilder(name)
    pts = np.vstack([s.line for s in net.streets])
    lo, hi = pts.min(axis=0) - 50.0, pts.max(axis=0) + 50.0
    b.rect("lawn", "grass", float(round(lo[0])), float(round(lo[1])), float(round(hi[0])), float(round(hi[1])), role="none",
           colour=GRASS, cost=5.0, reflectance=0.45)
    nodes = {}
    for j in net.junctions:
        c = np.array(j.xy)
        ends = []
        for h in j.arms:
            u, n = np.array([math.cos(h), math.sin(h)]), np.array([-math.sin(h), math.cos(h)])
            ends += [c + n * rw / 2, c - n * rw / 2, c + u * reach + n * rw / 2, c + u * reach - n * rw / 2]
        hull = shapely.MultiPoint(ends).convex_hull
        b.area(f"int_{j.id}", "intersection", list(hull.exterior.coords)[:-1], role="path", colour=ASPHALT, cost=1.0, reflectance=0.3)
        nodes[j.id] = b.node(j.id, *j.xy, "intersection", obj=f"int_{j.id}")
    for pid, xy in net.places.items():
        nodes[pid] = b.node(pid, *xy, "place", name=pid)
    centres = {}
    for st in net.streets:
        centre = _trimmed(net, st, reach)
        centres[st.id] = centre
        marks = markings_for(net, st, centre) if markings_for is not None else ()
        r = b.strip(f"road_{st.id}", "road", [tuple(p) for p in centre], rw, role="path", colour=ASPHALT, cost=1.0,
                    reflectance=0.3, markings=marks)
        b.edge(f"e_{st.id}", nodes[st.a], nodes[st.b], mode="follow-road", objs=(r.id,), width=rw,
               via=[tuple(p) for p in st.line[1:-1]])
    if extra_road is not None:
        extra_road(net, b, centres)
    site = _Site(shapely.union_all([o.footprint for o in b.objects if o.kind in ("road", "intersection")]))
    dest_side = 1.0 if rng.random() < 0.5 else -1.0
    if not _destination(b, net, site, rng, style, dest_side):
        return None
    facts = {"driveways": {}, "trees": 0, "houses": 0, "signs": 0, "hydrants": 0}
    _corners(b, net, site, rng, style, reach, facts)
    for st in net.streets:
        for side in (1.0, -1.0):
            _lots(b, st, centres[st.id], side, site, rng, style, facts)
    if style.tree_row_m is not None:
        for st in net.streets:
            _tree_row(b, st, centres[st.id], site, rng, style, facts)
    if facts["signs"] == 0 or facts["hydrants"] == 0 or len(facts["driveways"]) < 2:
        return None
    sun = Sun(azimuth_deg=round(float(rng.uniform(0.0, 360.0)), 1), elevation_deg=round(float(rng.uniform(*style.sun_elevation_deg)), 1))
    weather = Weather(wet_cover=round(float(rng.uniform(*style.wet_cover)), 3), leaf_cover=round(float(rng.uniform(*style.leaf_cover)), 3),
                      period_s=round(float(rng.uniform(240.0, 600.0))))
    start = StartPose(x=0.0, y=0.0, yaw_deg=round(math.degrees(net.start_yaw), 3), node="start")
    world = b.world(sun=sun, start=start, weather=weather)
    facts.update(_describe(net, dest_side))
    mission = _mission(name, seed, style, net, facts)
    actors = _actors(net, rw, rng)
    return StreetWorld(name, seed, style.kind, world, mission, actors, net, facts)


def _destination(b: WorldBuilder, net: StreetNetwork, site: _Site, rng: np.random.Generator, style: StreetStyle, side: float) -> bool:
    """Add the delivery mailbox beside the `mailbox` place on `side` (+1 left of travel), its driveway, house and hedge."""
    rw = style.road_width_m
    st = next(s for s in net.streets if s.b == "mailbox")
    line = shapely.LineString(st.line)
    c, u, n = _frame(line, line.length)
    n = n * side
    mb = c + n * (rw / 2 + _clearance(rng, style, "mailbox", 0.25, 0.5))
    b.round_obj("mailbox_dest", "mailbox", float(mb[0]), float(mb[1]), 0.25, role="landmark", colour=RED,
                shape=PostShape(height=1.15), name="delivery mailbox", reflectance=0.85)
    d = c - u * 4.0
    b.strip("drive_dest", "driveway", [tuple(d + n * (rw / 2 - 0.05)), tuple(d + n * (rw / 2 + 14.0))], 3.5, role="path",
            colour=DRIVEWAYS[int(rng.integers(0, len(DRIVEWAYS)))], cost=2.0, reflectance=0.35)
    hc = c + n * (rw / 2 + 24.0)
    corners = [hc + u * su * 6.0 + n * sn * 5.0 for su, sn in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    b.area("house_dest", "building", [tuple(q) for q in corners], role="landmark", colour=SIDING[0], shape=PrismShape(height=7.5),
           name="destination house", reflectance=0.6)
    hedge = [c + u * 5.0 + n * (rw / 2 + 4.5), c + u * 5.0 + n * (rw / 2 + 12.0)]
    b.strip("hedge_dest", "hedge", [tuple(q) for q in hedge], 1.0, role="obstacle", colour=HEDGE, shape=PrismShape(height=1.2), reflectance=0.3)
    placed = b.objects[-4:]
    if any(o.footprint.distance(site.roads) < ROADSIDE_CLEARANCE.get(o.kind, 0.0) for o in placed):
        return False
    site.solids += [o.footprint for o in placed]
    return True


def _corners(b: WorldBuilder, net: StreetNetwork, site: _Site, rng: np.random.Generator, style: StreetStyle, reach: float,
             facts: dict) -> None:
    """Add a stop sign on the right of the route's way into every crossing (and of some other streets), a hydrant at some corners."""
    rw = style.road_width_m
    for j in net.junctions:
        c = np.array(j.xy)
        for k, h in enumerate(j.arms):
            u = np.array([math.cos(h), math.sin(h)])
            right_in = np.array([-u[1], u[0]])  # the right of a vehicle driving in along -u
            if k == 0 or rng.random() < 0.4:
                p = c + u * (reach + 1.5) + right_in * (rw / 2 + _clearance(rng, style, "sign", 0.08, 0.8))
                g = shapely.Point(p).buffer(0.08)
                if site.roadside_ok("sign", g):
                    b.round_obj(f"sign_{j.id}_{k}", "sign", float(p[0]), float(p[1]), 0.08, role="landmark", colour=RED,
                                shape=PostShape(height=2.4), name="stop sign", reflectance=0.9)
                    site.solids.append(g)
                    facts["signs"] += 1
            if rng.random() < 0.3:
                p = c + u * (reach + float(rng.uniform(3.0, 8.0))) - right_in * (rw / 2 + _clearance(rng, style, "hydrant", 0.2, 0.8))
                g = shapely.Point(p).buffer(0.2)
                if site.roadside_ok("hydrant", g):
                    b.round_obj(f"hydrant_{j.id}_{k}", "hydrant", float(p[0]), float(p[1]), 0.2, role="landmark", colour=RED,
                                shape=PostShape(height=0.8), name="hydrant", reflectance=0.8)
                    site.solids.append(g)
                    facts["hydrants"] += 1


def _lots(b: WorldBuilder, st: Street, centre: np.ndarray, side: float, site: _Site, rng: np.random.Generator,
          style: StreetStyle, facts: dict) -> None:
    """Add lots along one side of a street (+1 left of a -> b): driveway, house, mailbox, trees; what does not fit is left out."""
    rw = style.road_width_m
    line = shapely.LineString(centre)
    own = line.buffer(rw / 2 + 0.5, cap_style="flat")
    others = site.roads.difference(own)
    s = 5.0 + float(rng.uniform(0.0, 4.0))
    k = 0
    while s < line.length - 5.0:
        lot = float(rng.uniform(*style.lot_m))
        k += 1
        tag = f"{st.id}_{'l' if side > 0 else 'r'}{k:02d}"
        c, u, n = _frame(line, s)
        n = n * side
        width = float(rng.uniform(3.0, 4.5))
        surface = int(rng.integers(0, len(DRIVEWAYS)))
        house = rng.random() < style.lot_share
        hw, hd = float(rng.uniform(11.0, 15.0)), float(rng.uniform(9.0, 12.0))
        front = float(rng.uniform(16.0, 20.0))
        n_trees = int(rng.integers(style.trees_per_lot[0], style.trees_per_lot[1] + 1))
        draws = rng.uniform(0.0, 1.0, size=(n_trees, 3))
        s_next = s + lot
        drive = shapely.LineString([c + n * (rw / 2 - 0.05), c + n * (rw / 2 + 14.0)]).buffer(width / 2, cap_style="flat")
        if drive.distance(others) < 1.0 or not site.free(drive, 1.5):
            s = s_next
            continue
        hc = c + u * float(rng.uniform(-3.0, 3.0)) + n * (rw / 2 + front + hd / 2)
        corners = [hc + u * su * hw / 2 + n * sn * hd / 2 for su, sn in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        hp = shapely.Polygon(corners)
        if house and (hp.distance(site.roads) < ROADSIDE_CLEARANCE["building"] + 0.5 or not site.free(hp, 2.0)):
            s = s_next
            continue
        b.strip(f"drive_{tag}", "driveway", [tuple(c + n * (rw / 2 - 0.05)), tuple(c + n * (rw / 2 + 14.0))], width, role="path",
                colour=DRIVEWAYS[surface], cost=2.0, reflectance=0.35)
        site.solids.append(drive)
        facts["driveways"][DRIVEWAY_NAMES[surface]] = facts["driveways"].get(DRIVEWAY_NAMES[surface], 0) + 1
        if house:
            b.area(f"house_{tag}", "building", [tuple(q) for q in corners], role="landmark", colour=SIDING[k % len(SIDING)],
                   shape=PrismShape(height=round(float(rng.uniform(6.0, 9.0)), 2)), reflectance=0.6)
            site.solids.append(hp)
            facts["houses"] += 1
            mb = c + u * (width / 2 + 1.2) + n * (rw / 2 + _clearance(rng, style, "mailbox", 0.25, 0.5))
            g = shapely.Point(mb).buffer(0.25)
            if site.roadside_ok("mailbox", g):
                b.round_obj(f"mailbox_{tag}", "mailbox", float(mb[0]), float(mb[1]), 0.25, role="landmark", colour=MAILBOX,
                            shape=PostShape(height=1.15), reflectance=0.8)
                site.solids.append(g)
        if style.tree_row_m is None:
            for t, (along, at_least, more) in enumerate(draws):
                off = (width / 2 + 2.0 + along * (lot - width - 4.0)) * (1.0 if t % 2 == 0 else -1.0)
                _tree(b, f"tree_{tag}_{t}", c + u * off, n, site, rng, style, at_least, more, facts)
        s = s_next


def _tree(b: WorldBuilder, oid: str, at: np.ndarray, n: np.ndarray, site: _Site, rng: np.random.Generator, style: StreetStyle,
          at_least: float, more: float, facts: dict) -> None:
    """Add a tree beside the road at `at` (a point on the centreline) along normal `n`, if it fits."""
    t = b.tree(oid, float(at[0]), float(at[1]), rng)  # drawn on the centreline, then moved out by its own trunk
    b.objects.pop()
    trunk = float(t.radius or 0.0)
    gap = ROADSIDE_CLEARANCE["tree"] + trunk + _EPS + (0.0 if at_least < style.at_least_share else 5.0 * more)
    p = at + n * (style.road_width_m / 2 + gap)
    g = shapely.Point(p).buffer(trunk)
    if not site.roadside_ok("tree", g):
        return
    b.objects.append(WorldObject(**{**{f: getattr(t, f) for f in WorldObject.model_fields},
                                    "center": (round(float(p[0]), 3), round(float(p[1]), 3))}))
    site.solids.append(g)
    facts["trees"] += 1


def _tree_row(b: WorldBuilder, st: Street, centre: np.ndarray, site: _Site, rng: np.random.Generator, style: StreetStyle,
              facts: dict) -> None:
    """Add a row of roadside trees along both sides of a street, `tree_row_m` apart (the shadows across a marked road)."""
    line = shapely.LineString(centre)
    k = 0
    for s in np.arange(4.0, line.length - 4.0, style.tree_row_m or 11.0):
        c, _, n = _frame(line, float(s) + float(rng.uniform(-2.0, 2.0)))
        side = 1.0 if rng.random() < 0.5 else -1.0
        draws = rng.uniform(0.0, 1.0, size=2)
        _tree(b, f"tree_{st.id}_row{k:02d}", c, n * side, site, rng, style, float(draws[0]), float(draws[1]), facts)
        k += 1


def _describe(net: StreetNetwork, dest_side: float) -> dict:
    return {
        "crossings": [{"node": j.id, "angle_deg": j.angle_deg, "turn": j.turn, "kind": j.kind} for j in net.junctions],
        "bends": [{"radius_m": round(r, 1), "turn_deg": round(d, 1)} for r, d in net.bends],
        "destination_side": "left" if dest_side > 0 else "right",
        "route": list(net.route),
        "route_m": round(float(np.sum(np.hypot(*np.diff(net.route_line(), axis=0).T))), 1),
    }


def _mission(name: str, seed: int, style: StreetStyle, net: StreetNetwork, facts: dict) -> dict:
    turns = ", ".join(f"{j.turn} at {j.id} ({j.kind}, {j.angle_deg:.0f}°)" for j in net.junctions)
    return {
        "mission": name,
        "description": f"{style.kind} seed {seed}: delivery from the start to the mailbox on the {facts['destination_side']}, "
                       f"{facts['route_m']:.0f} m: {turns}",
        "world": name, "vehicle": style.vehicle,
        "steps": [{"name": "to the mailbox", "destination": "mailbox", "constraints": ["keep_right", {"speed_limit": style.speed_limit}],
                   "trigger": "stop"}],
    }


def _actors(net: StreetNetwork, rw: float, rng: np.random.Generator) -> dict:
    """Return the actors document: a walker stepping into the lane on the first street, a car parked in the lane further on."""
    route = shapely.LineString(net.route_line())
    first = next(s for s in net.streets if s.a == "start")
    s_w = first.length * float(rng.uniform(0.4, 0.6))
    c, u, n = _frame(route, s_w)
    right = -n

    def wp(p: np.ndarray, **kw) -> dict:
        return {"x": round(float(p[0]), 3), "y": round(float(p[1]), 3), **kw}

    walker = {"id": "walker", "kind": "pedestrian", "speed": 1.4, "trigger_distance": 30.0,
              "path": [wp(c + right * (rw / 2 + 2.0)), wp(c + right * 0.5, dwell=30.0), wp(c - right * (rw / 2 + 3.0))]}
    junction_s = [route.project(shapely.Point(j.xy)) for j in net.junctions]
    lo, hi = 0.5 * route.length, route.length - 70.0
    car_s = None
    for s in np.linspace(lo, hi, 40)[rng.permutation(40)]:
        if all(abs(float(s) + d - js) > 25.0 for js in junction_s for d in (0.0, 15.0, 30.0, 45.0)):
            car_s = float(s)
            break
    car_s = car_s if car_s is not None else lo
    lane = [(_frame(route, car_s + d)) for d in (0.0, 15.0, 30.0, 45.0)]
    path = [wp(p - q * rw / 4) for p, _, q in lane]
    car = {"id": "parked_car", "kind": "car", "speed": 5.0, "trigger_distance": 25.0, "start_after": 30.0,
           "yaw_deg": round(math.degrees(math.atan2(lane[0][1][1], lane[0][1][0])), 2), "vanish": True, "path": path}
    return {"actors": [walker, car]}


class StreetWorldError(SimError, ValueError):
    """No draw of a street world of this seed passed (the message says what was tried)."""


def generate_street_world(kind: str, seed: int, name: str, net_params: NetworkParams, style: StreetStyle, *, salt: int,
                          attempts: int = 40, markings_for: MarkingsFor | None = None,
                          extra_road: EXTRA_ROAD | None = None) -> StreetWorld:
    """Draw networks from (`seed`, attempt, `salt`) until one is apart and furnishable; return its world."""
    for attempt in range(attempts):
        rng = np.random.default_rng([seed, attempt, salt])
        net = draw_network(rng, net_params)
        if net is None:
            continue
        out = build_street_world(name, seed, net, rng, style, net_params.reach_m, markings_for, extra_road)
        if out is not None:
            return out
    raise StreetWorldError(f"{kind} seed {seed}: no street network of {attempts} draws was apart and furnishable")


def write_street_world(sw: StreetWorld, out: str | Path) -> list[Path]:
    """Write the world, its map (the shipped maps' error, drawn from the seed), the mission and the actors; check them; return the paths."""
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    n = sw.name
    paths = [d / f"{n}.world.geojson", d / f"{n}.map.geojson", d / f"{n}.yaml", d / f"{n}.actors.yaml"]
    sw.world.save(paths[0])
    map_for(sw.world, 1.0, sw.seed).save(paths[1])
    default = f"{sw.kind.replace('-', '_')}_{sw.seed}"
    cmd = f"sidewalk worldgen {sw.kind} --seed {sw.seed}" + ("" if n == default else f" --name {n}")
    head = f"# generated by `{cmd}`\n"
    paths[2].write_text(head + yaml.safe_dump(sw.mission, sort_keys=False, allow_unicode=True))
    paths[3].write_text(head + "# a walker steps into the lane on the first street, a car is parked in the lane further on\n"
                        + yaml.safe_dump(sw.actors, sort_keys=False))
    check_written(paths[0], paths[1], paths[2], paths[3], sw.network.route)
    return paths
