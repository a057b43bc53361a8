"""Generate the shipped worlds (`campus`, `north_hills`, `schenley`) deterministically and write them to worlds/.

Run `python -m vehicle_sim.worldgen` to regenerate worlds/*.world.geojson and the derived
worlds/*.map.geojson (default map error, fixed seed). Output is byte-identical run to run.

Every surface is a `Material`: what a map says of it (colour type and a catalogue nominal colour)
and how it looks in this world (colour statistics). Each object weathers on its own (a seeded
brightness and tint of its own, from its id), and each world has weather (wet patches, leaves).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vehicle_sim.worldfile import (
    WORLDS_DIR,
    Appearance,
    Marking,
    ColourStats,
    FlatShape,
    MapColour,
    PathEdge,
    PathNode,
    PostShape,
    PrismShape,
    SlopeShape,
    StairsShape,
    StartPose,
    Sun,
    TreeShape,
    Weather,
    World,
    WorldObject,
)

__all__ = ["Material", "WorldBuilder", "WEATHERING", "ROADSIDE_CLEARANCE", "build_campus", "build_north_hills", "build_schenley",
           "WORLD_BUILDERS",
           "write_worlds", "main"]


@dataclass(frozen=True)
class Material:
    """A surface: what a map says (colour type, catalogue nominal sRGB) and how it looks (mean, std under full sun) [0–255]."""

    type: str
    nominal: tuple[float, float, float]
    mean: tuple[float, float, float]
    std: tuple[float, float, float]

    def map_colour(self) -> MapColour:
        """Return the colour a map states for this material."""
        return MapColour(type=self.type, nominal=self.nominal)  # type: ignore[arg-type]


# ---- palette: the map's word for each material, and how it looks in these worlds -----------
CONCRETE = Material("GRAY", (175.0, 175.0, 170.0), (156.0, 154.0, 148.0), (9.0, 9.0, 9.0))
GRASS = Material("GREEN", (85.0, 135.0, 60.0), (74.0, 122.0, 52.0), (14.0, 18.0, 12.0))
ASPHALT = Material("GRAY", (80.0, 80.0, 80.0), (88.0, 88.0, 92.0), (8.0, 8.0, 8.0))
BRICK = Material("BROWN", (160.0, 80.0, 60.0), (152.0, 86.0, 66.0), (12.0, 10.0, 10.0))
BUFF = Material("YELLOW", (200.0, 180.0, 130.0), (196.0, 176.0, 134.0), (10.0, 10.0, 9.0))
SIDING = (Material("WHITE", (230.0, 230.0, 220.0), (214.0, 210.0, 196.0), (6.0, 6.0, 6.0)),
          Material("GRAY", (170.0, 180.0, 190.0), (170.0, 184.0, 196.0), (6.0, 6.0, 6.0)),
          Material("YELLOW", (210.0, 180.0, 120.0), (200.0, 170.0, 120.0), (6.0, 6.0, 6.0)))
TRUNK = Material("BROWN", (90.0, 70.0, 50.0), (92.0, 72.0, 54.0), (10.0, 8.0, 8.0))
CROWN = ColourStats(mean=(44.0, 92.0, 38.0), std=(16.0, 20.0, 14.0))
METAL = Material("GRAY", (70.0, 70.0, 70.0), (60.0, 62.0, 66.0), (6.0, 6.0, 6.0))
MAILBOX = Material("BLUE", (40.0, 50.0, 130.0), (40.0, 48.0, 120.0), (6.0, 6.0, 8.0))
WOOD = Material("BROWN", (130.0, 100.0, 60.0), (130.0, 98.0, 64.0), (10.0, 8.0, 8.0))
HEDGE = Material("GREEN", (40.0, 85.0, 35.0), (36.0, 80.0, 34.0), (10.0, 14.0, 10.0))
GRAVEL = Material("BROWN", (170.0, 155.0, 130.0), (168.0, 156.0, 134.0), (18.0, 18.0, 18.0))
RED = Material("RED", (180.0, 40.0, 35.0), (170.0, 40.0, 36.0), (8.0, 6.0, 6.0))
STONE = Material("GRAY", (130.0, 125.0, 115.0), (128.0, 124.0, 116.0), (10.0, 10.0, 10.0))
PAVERS = Material("BROWN", (120.0, 85.0, 70.0), (120.0, 84.0, 70.0), (10.0, 8.0, 8.0))
#: Least distance [m] from a road or intersection area to the footprint of each roadside kind (north_hills).
ROADSIDE_CLEARANCE = {"tree": 2.5, "mailbox": 0.5, "building": 8.0, "hedge": 0.5, "sign": 1.0, "hydrant": 1.0}
DRIVEWAYS = (CONCRETE, ASPHALT, GRAVEL, PAVERS)
#: How much objects of one material differ: relative brightness spread (std) and tint spread per channel [DN].
WEATHERING = (0.07, 3.0)


def _weathered(world: str, oid: str, stats: Material | ColourStats, salt: str = "") -> tuple[float, float, float]:
    """Return the mean colour of one object of a material after its own weathering, seeded by its id [0–255]."""
    rng = np.random.default_rng(zlib.crc32(f"{world}/{oid}{salt}".encode()))
    gain = float(np.clip(math.exp(rng.normal(0.0, WEATHERING[0])), 0.75, 1.3))
    tint = rng.normal(0.0, WEATHERING[1], size=3)
    return tuple(float(round(min(max(m * gain + t, 0.0), 255.0), 1)) for m, t in zip(stats.mean, tint))  # type: ignore[return-value]


@dataclass
class _Builder:
    """Accumulate objects, nodes and edges with unique ids."""

    name: str
    objects: list[WorldObject] = field(default_factory=list)
    nodes: list[PathNode] = field(default_factory=list)
    edges: list[PathEdge] = field(default_factory=list)

    # ---- objects ----
    def look(self, oid: str, material: Material, reflectance: float, crown: ColourStats | None = None) -> Appearance:
        """Return how object `oid` of `material` looks in this world: weathered on its own."""
        if crown is not None:
            crown = ColourStats(mean=_weathered(self.name, oid, crown, "/crown"), std=crown.std)
        return Appearance(mean=_weathered(self.name, oid, material), std=material.std, reflectance=reflectance, crown=crown)

    def area(self, oid: str, kind: str, pts, *, role: str, colour: Material, shape=None, cost: float = math.inf, name: str | None = None, reflectance: float = 0.5,
             markings: tuple[Marking, ...] = ()) -> WorldObject:
        poly = tuple((round(float(x), 3), round(float(y), 3)) for x, y in pts)
        obj = WorldObject(id=oid, kind=kind, role=role, cost=cost, colour=colour.map_colour(), appearance=self.look(oid, colour, reflectance),
                          shape=shape or FlatShape(z=0.0), name=name, polygon=poly, markings=markings)
        self.objects.append(obj)
        return obj

    def rect(self, oid: str, kind: str, x0: float, y0: float, x1: float, y1: float, **kw) -> WorldObject:
        return self.area(oid, kind, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)], **kw)

    def strip(self, oid: str, kind: str, centreline, width: float, **kw) -> WorldObject:
        """Add a band of `width` [m] along a polyline (flat ends)."""
        import shapely

        line = shapely.LineString(centreline)
        poly = line.buffer(width / 2.0, cap_style="flat", join_style="mitre", mitre_limit=3.0)
        poly = shapely.simplify(poly, 0.01)
        return self.area(oid, kind, list(poly.exterior.coords)[:-1], **kw)

    def round_obj(self, oid: str, kind: str, x: float, y: float, radius: float, *, role: str, colour: Material, shape, name: str | None = None,
                  reflectance: float = 0.5, crown: ColourStats | None = None) -> WorldObject:
        obj = WorldObject(id=oid, kind=kind, role=role, colour=colour.map_colour(), appearance=self.look(oid, colour, reflectance, crown),
                          shape=shape, name=name, center=(round(float(x), 3), round(float(y), 3)), radius=radius)
        self.objects.append(obj)
        return obj

    def tree(self, oid: str, x: float, y: float, rng: np.random.Generator, *, z0: float = 0.0, scale: float = 1.0) -> WorldObject:
        h = float(rng.uniform(6.0, 10.0)) * scale
        crown = float(rng.uniform(1.8, 3.2)) * scale
        trunk = round(float(rng.uniform(0.15, 0.3)), 3)
        shape = TreeShape(trunk_radius=trunk, crown_radius=round(crown, 2), height=round(h, 2), crown_base=round(h * 0.4, 2), z0=z0)
        return self.round_obj(oid, "tree", x, y, trunk, role="obstacle", colour=TRUNK, shape=shape, reflectance=0.35, crown=CROWN)

    def keep_clear(self, path_kinds: tuple[str, ...], clearance: dict[str, float], droppable: tuple[str, ...] = ("tree",)) -> None:
        """Keep standing objects `clearance[kind]` [m] outside every area of `path_kinds`: drop droppable ones, else raise."""
        import shapely

        paths = shapely.union_all([o.footprint for o in self.objects if o.kind in path_kinds])
        kept = []
        for o in self.objects:
            need = clearance.get(o.kind)
            if need is not None and o.footprint.distance(paths) < need:
                if o.kind not in droppable:
                    raise ValueError(f"world {self.name}: {o.kind} {o.id} is {o.footprint.distance(paths):.2f} m from a "
                                     f"{'/'.join(path_kinds)} area, less than the {need} m it needs")
                continue
            kept.append(o)
        self.objects[:] = kept

    # ---- graph ----
    def node(self, nid: str, x: float, y: float, kind: str = "intersection", name: str | None = None, obj: str | None = None) -> PathNode:
        n = PathNode(id=nid, node_kind=kind, x=float(x), y=float(y), name=name, object_id=obj)  # type: ignore[arg-type]
        self.nodes.append(n)
        return n

    def edge(self, eid: str, a: PathNode, b: PathNode, *, mode: str, objs, width: float, via=()) -> PathEdge:
        coords = ((a.x, a.y), *tuple((float(x), float(y)) for x, y in via), (b.x, b.y))
        e = PathEdge(id=eid, from_node=a.id, to_node=b.id, mode=mode, path_objects=tuple(objs), width=width, coords=coords)  # type: ignore[arg-type]
        self.edges.append(e)
        return e

    def world(self, *, sun: Sun, start: StartPose, weather: Weather | None = None) -> World:
        return World(name=self.name, objects=self.objects, nodes=self.nodes, edges=self.edges, sun=sun, start=start,
                     weather=weather, source=f"<worldgen:{self.name}>")


#: The builder of worlds: objects with their map colour and their own weathered look (the generated worlds use it too).
WorldBuilder = _Builder


# =========================================================================================
# campus


def build_campus() -> World:
    """Build the CMU-like campus: a sidewalk grid, a quad, a terrace reached by stairs or by a slope beside them."""
    rng = np.random.default_rng(1986)
    b = _Builder("campus")
    TZ = 1.05  # terrace height [m] (7 steps of 0.15 m)

    # ground: the lower lawn, then the terrace lawn, then the sloped lawn beside the ramp
    b.rect("grass_lower", "grass", -45.0, -50.0, 240.0, 72.0, role="none", colour=GRASS, cost=4.0, reflectance=0.45)
    b.rect("grass_terrace", "grass", -45.0, 72.0, 240.0, 135.0, role="none", colour=GRASS, cost=4.0, shape=FlatShape(z=TZ), reflectance=0.45)
    b.rect("grass_bank", "grass", 68.0, 61.5, 82.0, 72.0, role="none", colour=GRASS, cost=4.0,
           shape=SlopeShape(z0=0.0, rise=TZ, axis_deg=90.0), reflectance=0.45)

    # intersection nodes (lower level), sidewalk grid
    W_MAIN, W_SIDE = 3.0, 2.5
    lower = {
        "i_dorm_walk": (0.0, 0.0), "i_hall": (60.0, 0.0), "i_quad_s": (90.0, 0.0), "i_science": (120.0, 0.0), "i_gym_walk": (180.0, 0.0),
        "i_west": (0.0, 60.0), "i_stairs": (60.0, 60.0), "i_quad_n": (90.0, 60.0), "i_east": (120.0, 60.0),
    }
    terrace = {"i_terrace": (60.0, 88.0)}
    nodes: dict[str, PathNode] = {}
    for nid, (x, y) in {**lower, **terrace}.items():
        z = TZ if nid in terrace else 0.0
        s = W_MAIN + 0.5
        b.rect(f"x_{nid[2:]}", "intersection", x - s / 2, y - s / 2, x + s / 2, y + s / 2, role="path", colour=CONCRETE, cost=1.0,
               shape=FlatShape(z=z), reflectance=0.55)
        nodes[nid] = b.node(nid, x, y, "intersection", obj=f"x_{nid[2:]}")

    def walk(eid: str, a: str | PathNode, c: str | PathNode, width: float, *, z: float = 0.0, mode: str = "follow-road", extra=()):
        na = nodes[a] if isinstance(a, str) else a
        nc = nodes[c] if isinstance(c, str) else c
        d = np.array([nc.x - na.x, nc.y - na.y])
        L = float(np.linalg.norm(d))
        u = d / L
        trim_a = (W_MAIN + 0.5) / 2 if na.node_kind == "intersection" else 0.0
        trim_c = (W_MAIN + 0.5) / 2 if nc.node_kind == "intersection" else 0.0
        p0 = np.array([na.x, na.y]) + u * trim_a
        p1 = np.array([nc.x, nc.y]) - u * trim_c
        sw = b.strip(f"sw_{eid}", "sidewalk", [tuple(p0), tuple(p1)], width, role="path", colour=CONCRETE, cost=1.0,
                     shape=FlatShape(z=z), reflectance=0.55)
        b.edge(f"e_{eid}", na, nc, mode=mode, objs=(sw.id, *extra), width=width)
        return sw

    # places (lower)
    nodes["dorm"] = b.node("dorm", 0.0, -28.0, "place", name="dorm")
    nodes["gym"] = b.node("gym", 205.0, 0.0, "place", name="gym")
    nodes["observatory"] = b.node("observatory", 180.0, 42.0, "place", name="observatory")
    nodes["quad"] = b.node("quad", 90.0, 30.0, "place", name="quad")
    nodes["hall"] = b.node("hall", 30.0, 8.0, "place", name="hall")
    nodes["slope_bottom"] = b.node("slope_bottom", 66.0, 60.0, "place", name="slope_bottom")
    nodes["stairs_bottom"] = b.node("stairs_bottom", 60.0, 64.0, "place", name="stairs_bottom")
    nodes["stairs_top"] = b.node("stairs_top", 60.0, 74.0, "place", name="stairs_top")
    nodes["library"] = b.node("library", 60.0, 104.0, "place", name="library")
    nodes["museum"] = b.node("museum", 0.0, 88.0, "place", name="museum")
    nodes["chapel"] = b.node("chapel", 120.0, 88.0, "place", name="chapel")

    # the lower grid
    walk("dorm", "dorm", "i_dorm_walk", W_SIDE)
    walk("s1", "i_dorm_walk", "i_hall", W_MAIN)
    walk("s2", "i_hall", "i_quad_s", W_MAIN)
    walk("s3", "i_quad_s", "i_science", W_MAIN)
    walk("s4", "i_science", "i_gym_walk", W_MAIN)
    walk("gym", "i_gym_walk", "gym", W_MAIN)
    walk("obs", "i_gym_walk", "observatory", W_SIDE)
    walk("west", "i_dorm_walk", "i_west", W_SIDE)
    walk("hall_ns", "i_hall", "i_stairs", W_SIDE)
    walk("quad_s", "i_quad_s", "quad", 2.0)
    walk("quad_n", "quad", "i_quad_n", 2.0)
    walk("east", "i_science", "i_east", W_SIDE)
    walk("n1", "i_west", "i_stairs", W_MAIN)
    walk("n2a", "i_stairs", "slope_bottom", W_MAIN)
    walk("n2b", "slope_bottom", "i_quad_n", W_MAIN)
    walk("n3", "i_quad_n", "i_east", W_MAIN)
    # the hall entrance spur
    b.rect("sw_hall_spur", "sidewalk", 28.75, 1.5, 31.25, 8.0, role="path", colour=CONCRETE, cost=1.0, reflectance=0.55)
    b.edge("e_hall_spur", nodes["hall"], nodes["i_hall"], mode="follow-road", objs=("sw_hall_spur", "sw_s1"), width=2.5, via=((30.0, 0.0),))

    # stairs and the slope beside them: same concrete grey
    b.rect("sw_stairs_approach", "sidewalk", 58.5, 61.5, 61.5, 66.0, role="path", colour=CONCRETE, cost=1.0, reflectance=0.55)
    b.edge("e_stairs_approach", nodes["i_stairs"], nodes["stairs_bottom"], mode="follow-road", objs=("sw_stairs_approach",), width=3.0)
    b.rect("stairs_main", "stairs", 57.0, 66.0, 63.0, 72.0, role="path", colour=CONCRETE, cost=1.5,
           shape=StairsShape(z0=0.0, rise=TZ, axis_deg=90.0, step_rise=0.15), name="main stairs", reflectance=0.55)
    b.rect("slope_ramp", "slope", 64.0, 61.5, 68.0, 72.0, role="path", colour=CONCRETE, cost=1.2,
           shape=SlopeShape(z0=0.0, rise=TZ, axis_deg=90.0), name="ramp", reflectance=0.55)
    b.rect("sw_plaza", "sidewalk", 55.0, 72.0, 70.0, 77.0, role="path", colour=CONCRETE, cost=1.0, shape=FlatShape(z=TZ), name="plaza", reflectance=0.55)
    b.edge("e_stairs", nodes["stairs_bottom"], nodes["stairs_top"], mode="climb-stairs", objs=("stairs_main", "sw_plaza"), width=6.0)
    b.edge("e_slope", nodes["slope_bottom"], nodes["stairs_top"], mode="go-through-slope", objs=("slope_ramp", "sw_plaza"), width=4.0,
           via=((66.0, 72.0), (66.0, 74.0)))
    # the terrace edge: a retaining wall, except where the stairs, the ramp and the bank are
    b.rect("wall_w", "wall", -45.0, 71.7, 57.0, 72.0, role="obstacle", colour=STONE, shape=PrismShape(height=TZ + 0.4), reflectance=0.5)
    b.rect("wall_e", "wall", 82.0, 71.7, 240.0, 72.0, role="obstacle", colour=STONE, shape=PrismShape(height=TZ + 0.4), reflectance=0.5)
    b.rect("wall_stairs_w", "wall", 56.6, 66.0, 57.0, 72.0, role="obstacle", colour=STONE,
           shape=PrismShape(height=TZ + 0.4), reflectance=0.5)

    # the terrace walks
    walk("t_up", "stairs_top", "i_terrace", W_MAIN, z=TZ)
    walk("t_w", "museum", "i_terrace", W_SIDE, z=TZ)
    walk("t_e", "i_terrace", "chapel", W_SIDE, z=TZ)
    walk("t_lib", "i_terrace", "library", W_MAIN, z=TZ)

    # buildings
    def building(oid, x0, y0, x1, y1, h, colour, name, z0=0.0):
        b.rect(oid, "building", x0, y0, x1, y1, role="landmark", colour=colour, shape=PrismShape(height=h, z0=z0), name=name, reflectance=0.6)

    building("b_hall", 12.0, 10.0, 48.0, 40.0, 14.0, BUFF, "Hamerschlag Hall")
    building("b_science", 132.0, 12.0, 170.0, 46.0, 16.0, BRICK, "Science Hall")
    building("b_gym", 208.0, -15.0, 236.0, 15.0, 10.0, BRICK, "Gymnasium")
    building("b_dorm", -15.0, -48.0, 15.0, -31.0, 12.0, BUFF, "Dormitory")
    building("b_library", 44.0, 107.0, 76.0, 130.0, 12.0, BRICK, "Hunt Library", z0=TZ)
    building("b_museum", -40.0, 80.0, -4.0, 100.0, 10.0, BUFF, "Museum", z0=TZ)
    building("b_chapel", 124.0, 80.0, 150.0, 100.0, 15.0, STONE, "Chapel", z0=TZ)
    building("b_obs", 172.0, 45.0, 188.0, 61.0, 8.0, STONE, "Observatory")

    # trees along walks (south of E-W walks, so shadows fall across them), in the quad and on the terrace
    k = 0
    for x in np.arange(6.0, 176.0, 11.0):
        if abs(x - 60) < 4 or abs(x - 90) < 4 or abs(x - 120) < 4 or abs(x - 30) < 3:
            continue
        b.tree(f"tree_{k:03d}", float(x + rng.uniform(-1, 1)), float(-4.5 - rng.uniform(0, 1.5)), rng)
        k += 1
    for x in np.arange(8.0, 116.0, 13.0):
        if abs(x - 60) < 5 or abs(x - 90) < 4:
            continue
        b.tree(f"tree_{k:03d}", float(x + rng.uniform(-1, 1)), float(55.0 - rng.uniform(0, 1.5)), rng)
        k += 1
    for y in np.arange(8.0, 56.0, 12.0):
        b.tree(f"tree_{k:03d}", float(-4.5 - rng.uniform(0, 1)), float(y + rng.uniform(-1, 1)), rng)
        k += 1
        b.tree(f"tree_{k:03d}", float(124.5 + rng.uniform(0, 1)), float(y + rng.uniform(-1, 1)), rng)
        k += 1
    for (x, y) in ((72.0, 14.0), (106.0, 18.0), (74.0, 44.0), (104.0, 46.0), (80.0, 30.0)):
        b.tree(f"tree_{k:03d}", x, y, rng, scale=1.2)
        k += 1
    for x in (10.0, 24.0, 38.0, 82.0, 96.0, 110.0):
        b.tree(f"tree_{k:03d}", x + float(rng.uniform(-1, 1)), 83.5, rng, z0=TZ)
        k += 1

    # landmarks: lamp posts, benches, signs
    j = 0
    for (x, y) in ((62.5, 2.5), (122.5, 2.5), (2.5, 62.5), (92.0, 28.0), (182.5, 2.5), (62.5, 57.5), (57.5, 86.0)):
        b.round_obj(f"lamp_{j:02d}", "lamp_post", x, y, 0.12, role="landmark", colour=METAL, shape=PostShape(height=4.0, z0=TZ if y > 72 else 0.0), reflectance=0.7)
        j += 1
    b.rect("bench_quad_1", "bench", 91.5, 34.0, 92.3, 36.0, role="obstacle", colour=WOOD, shape=PrismShape(height=0.45), reflectance=0.4)
    b.rect("bench_quad_2", "bench", 87.7, 24.0, 88.5, 26.0, role="obstacle", colour=WOOD, shape=PrismShape(height=0.45), reflectance=0.4)
    b.round_obj("sign_gym", "sign", 200.0, 2.5, 0.08, role="landmark", colour=RED, shape=PostShape(height=2.2), name="gym sign", reflectance=0.8)
    b.round_obj("sign_library", "sign", 62.5, 100.0, 0.08, role="landmark", colour=RED, shape=PostShape(height=2.2, z0=TZ), name="library sign", reflectance=0.8)
    b.rect("hedge_quad", "hedge", 63.0, 3.0, 87.0, 4.0, role="obstacle", colour=HEDGE, shape=PrismShape(height=1.0), reflectance=0.3)

    return b.world(sun=Sun(azimuth_deg=215.0, elevation_deg=35.0), start=StartPose(x=0.0, y=-28.0, yaw_deg=90.0, node="dorm"),
                   weather=Weather(wet_cover=0.06, leaf_cover=0.03, period_s=300.0))


# =========================================================================================
# north hills


def build_north_hills() -> World:
    """Build North Hills: suburban streets without markings, four intersections, a mail route with two left turns."""
    rng = np.random.default_rng(1990)
    b = _Builder("north_hills")
    RW = 6.0  # road width [m]
    XS = 9.0  # intersection square side [m]
    b.rect("lawn", "grass", -290.0, -60.0, 110.0, 340.0, role="none", colour=GRASS, cost=5.0, reflectance=0.45)

    # route: start (0,-40) north on Oak St through X1 (0,100), left at X2 (0,240) onto Elm Ave west,
    # through X3 (-120,240), left at X4 (-240,240) onto Birch Rd south, to the mailbox at (-240,130).
    xs = {"x_oak_maple": (0.0, 100.0), "x_oak_elm": (0.0, 240.0), "x_elm_pine": (-120.0, 240.0), "x_elm_birch": (-240.0, 240.0)}
    nodes: dict[str, PathNode] = {}
    for nid, (x, y) in xs.items():
        b.rect(f"int_{nid[2:]}", "intersection", x - XS / 2, y - XS / 2, x + XS / 2, y + XS / 2, role="path", colour=ASPHALT, cost=1.0, reflectance=0.3)
        nodes[nid] = b.node(nid, x, y, "intersection", obj=f"int_{nid[2:]}")
    places = {
        "start": (0.0, -40.0), "oak_north": (0.0, 300.0), "maple_east": (80.0, 100.0), "maple_west": (-80.0, 100.0),
        "pine_north": (-120.0, 320.0), "pine_south": (-120.0, 160.0), "birch_north": (-240.0, 300.0),
        "mailbox": (-240.0, 130.0), "birch_south": (-240.0, 60.0),
    }
    for nid, (x, y) in places.items():
        nodes[nid] = b.node(nid, x, y, "place", name=nid)

    road_len = 0.0

    def road(eid: str, a: str, c: str, via=()):
        nonlocal road_len
        na, nc = nodes[a], nodes[c]
        pts = [np.array([na.x, na.y]), *[np.array(v, dtype=float) for v in via], np.array([nc.x, nc.y])]
        if na.node_kind == "intersection":
            u = pts[1] - pts[0]
            pts[0] = pts[0] + u / np.linalg.norm(u) * XS / 2
        if nc.node_kind == "intersection":
            u = pts[-1] - pts[-2]
            pts[-1] = pts[-1] - u / np.linalg.norm(u) * XS / 2
        r = b.strip(f"road_{eid}", "road", [tuple(p) for p in pts], RW, role="path", colour=ASPHALT, cost=1.0, reflectance=0.3)
        e = b.edge(f"e_{eid}", na, nc, mode="follow-road", objs=(r.id,), width=RW, via=via)
        road_len += e.length
        return r

    # Oak St with a gentle curve between X1 and X2 (curving suburban street)
    curve = [(0.0 + 7.0 * math.sin(math.pi * t) ** 2, 100.0 + 140.0 * t) for t in np.linspace(0.05, 0.95, 19)]
    road("oak_1", "start", "x_oak_maple")
    road("oak_2", "x_oak_maple", "x_oak_elm", via=[(round(x, 3), round(y, 3)) for x, y in curve])
    road("oak_3", "x_oak_elm", "oak_north")
    road("maple_e", "x_oak_maple", "maple_east")
    road("maple_w", "x_oak_maple", "maple_west")
    elm_curve = [(round(-120.0 * t, 3), round(240.0 + 5.0 * math.sin(math.pi * t) ** 2, 3)) for t in np.linspace(0.05, 0.95, 19)]
    road("elm_1", "x_oak_elm", "x_elm_pine", via=elm_curve)
    road("elm_2", "x_elm_pine", "x_elm_birch")
    road("pine_n", "x_elm_pine", "pine_north")
    road("pine_s", "x_elm_pine", "pine_south")
    road("birch_n", "x_elm_birch", "birch_north")
    road("birch_1", "x_elm_birch", "mailbox")
    road("birch_2", "mailbox", "birch_south")

    # houses with driveways and mailboxes along the streets
    def house_lots(prefix: str, centreline, side: float, spacing: float, trim: float = 0.0):
        """Place lots along the road centreline polyline on `side` (+1 left, −1 right of travel), `trim` [m] clear of its ends."""
        import shapely

        line = shapely.LineString([tuple(map(float, p)) for p in centreline])
        L = float(line.length) - 2.0 * trim

        def frame(s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            a = line.interpolate(max(0.0, trim + s - 0.5))
            q = line.interpolate(min(line.length, trim + s + 0.5))
            u = np.array([q.x - a.x, q.y - a.y])
            u /= np.linalg.norm(u)
            p = line.interpolate(trim + s)
            return np.array([p.x, p.y]), u, np.array([-u[1], u[0]]) * side

        for i, s in enumerate(np.arange(spacing / 2, L - spacing / 3, spacing)):
            c, u, n = frame(float(s))
            dw = float(rng.uniform(-4.0, 4.0))
            drive_c, u, n = frame(float(s) + dw)
            kind_ix = int(rng.integers(0, len(DRIVEWAYS)))
            a = drive_c + n * (RW / 2 - 0.05)
            e = drive_c + n * (RW / 2 + 14.0)
            b.strip(f"drive_{prefix}{i:02d}", "driveway", [tuple(a), tuple(e)], float(rng.uniform(3.0, 4.5)), role="path",
                    colour=DRIVEWAYS[kind_ix], cost=2.0, reflectance=0.35)
            hc = c + n * (RW / 2 + 24.0)
            hw, hd = float(rng.uniform(11.0, 15.0)), float(rng.uniform(9.0, 12.0))
            corners = [hc + u * su * hw / 2 + n * sn * hd / 2 for su, sn in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            b.area(f"house_{prefix}{i:02d}", "building", [tuple(q) for q in corners], role="landmark", colour=SIDING[i % len(SIDING)],
                   shape=PrismShape(height=round(float(rng.uniform(6.0, 9.0)), 2)), reflectance=0.6)
            mb = drive_c + u * 3.2 + n * (RW / 2 + 1.0)
            b.round_obj(f"mailbox_{prefix}{i:02d}", "mailbox", float(mb[0]), float(mb[1]), 0.25, role="landmark", colour=MAILBOX,
                        shape=PostShape(height=1.15), reflectance=0.8)
            for t in range(int(rng.integers(1, 3))):
                tp = c + u * float(rng.uniform(-spacing / 2 + 3, spacing / 2 - 3)) + n * float(rng.uniform(RW / 2 + 4.0, RW / 2 + 10.0))
                if abs(float((tp - drive_c) @ u)) < 3.5:
                    continue
                b.tree(f"tree_{prefix}{i:02d}_{t}", float(tp[0]), float(tp[1]), rng)

    elm_line = [(0.0, 240.0), *elm_curve, (-120.0, 240.0)]
    house_lots("oakw", [(0.0, -30.0), (0.0, 90.0)], 1.0, 30.0)
    house_lots("oake", [(0.0, -30.0), (0.0, 90.0)], -1.0, 30.0)
    house_lots("elms", elm_line, 1.0, 33.0, trim=10.0)  # south side of the curving stretch
    house_lots("elmn", [(-130.0, 240.0), (-230.0, 240.0)], -1.0, 33.0)
    house_lots("elms2", [(-130.0, 240.0), (-230.0, 240.0)], 1.0, 33.0)
    house_lots("birw", [(-240.0, 230.0), (-240.0, 140.0)], -1.0, 30.0)
    house_lots("mapn", [(10.0, 100.0), (75.0, 100.0)], 1.0, 32.0)

    # the destination: the delivery mailbox on Birch Rd, east side, beside its driveway
    b.round_obj("mailbox_dest", "mailbox", -240.0 + RW / 2 + 1.0, 130.0, 0.25, role="landmark", colour=RED,
                shape=PostShape(height=1.15), name="delivery mailbox", reflectance=0.85)
    b.strip("drive_dest", "driveway", [(-240.0 + RW / 2 - 0.05, 126.0), (-240.0 + RW / 2 + 14.0, 126.0)], 3.5, role="path", colour=CONCRETE, cost=2.0, reflectance=0.35)
    b.rect("house_dest", "building", -222.0, 118.0, -210.0, 134.0, role="landmark", colour=SIDING[0], shape=PrismShape(height=7.5), name="destination house", reflectance=0.6)
    b.rect("hedge_dest", "hedge", -235.5, 134.5, -228.0, 135.5, role="obstacle", colour=HEDGE, shape=PrismShape(height=1.2), reflectance=0.3)
    # corner landmarks at the two turns
    b.round_obj("sign_oak_elm", "sign", 5.5, 245.5, 0.08, role="landmark", colour=RED, shape=PostShape(height=2.4), name="stop sign", reflectance=0.9)
    b.round_obj("hydrant_elm_birch", "hydrant", -234.5, 245.5, 0.2, role="landmark", colour=RED, shape=PostShape(height=0.8), name="hydrant", reflectance=0.8)
    b.round_obj("sign_elm_birch", "sign", -245.5, 234.5, 0.08, role="landmark", colour=RED, shape=PostShape(height=2.4), name="stop sign", reflectance=0.9)

    # Nothing stands in the road: roadside objects keep clear of every road and intersection area.
    b.keep_clear(("road", "intersection"), ROADSIDE_CLEARANCE)
    w = b.world(sun=Sun(azimuth_deg=160.0, elevation_deg=45.0), start=StartPose(x=0.0, y=-40.0, yaw_deg=90.0, node="start"),
                weather=Weather(wet_cover=0.08, leaf_cover=0.04, period_s=420.0))
    return w


# =========================================================================================
# schenley: marked roads for YARF


def _offset_line(centre, d: float) -> list[tuple[float, float]]:
    """Return the polyline `d` [m] left of `centre` (negative: right), rounded to mm (mitred vertex normals)."""
    p = np.asarray(centre, float)
    seg = np.diff(p, axis=0)
    seg /= np.linalg.norm(seg, axis=1, keepdims=True)
    t = np.vstack([seg[:1], seg[:-1] + seg[1:], seg[-1:]])
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    n = np.stack([-t[:, 1], t[:, 0]], axis=1)
    cos_half = np.ones(len(p))
    cos_half[1:-1] = np.maximum((n[1:-1] * np.stack([-seg[:-1, 1], seg[:-1, 0]], 1)).sum(1), 0.5)
    q = p + d * n / cos_half[:, None]
    return [(round(float(x), 3), round(float(y), 3)) for x, y in q]


def _clip_line(centre, x0: float, x1: float, axis: int = 0) -> list[tuple[float, float]]:
    """Return the part of `centre` whose coordinate `axis` lies in [x0, x1] (ends interpolated)."""
    import shapely

    box = shapely.box(x0, -1e4, x1, 1e4) if axis == 0 else shapely.box(-1e4, x0, 1e4, x1)
    part = shapely.line_merge(shapely.LineString(np.asarray(centre, float)).intersection(box))
    return [(round(float(x), 3), round(float(y), 3)) for x, y in part.coords]


def build_schenley() -> World:
    """Build Schenley: a marked two-lane road through a golf course (YARF's world, Navlab 1990 §2.2.2, ch. 5).

    Golf Course Rd runs east from `start` through a long bend to a four-way intersection, where a right
    turn lane is added over the last 45 m; Tee Dr crosses it north–south, East Dr continues east.
    Markings: a double yellow centre line (broken to a single dashed line in a passing zone), white
    edge stripes (the north one broken along the bend), a dashed lane line beside the added lane.
    Trees south of the road throw shadows across it (sun from the south-south-west).
    """
    rng = np.random.default_rng(1989)
    b = _Builder("schenley")
    RW = 7.6  # road width [m]: two 3.5 m lanes and a 0.3 m shoulder outside each edge stripe
    EDGE = 3.55  # edge stripe centre from the spine [m]
    XS = 12.0  # intersection square side [m]
    b.rect("fairway", "grass", -40.0, -110.0, 330.0, 150.0, role="none", colour=GRASS, cost=5.0, reflectance=0.45)
    xc = (220.0, 0.0)
    b.rect("int_club", "intersection", xc[0] - XS / 2, xc[1] - XS / 2, xc[0] + XS / 2, xc[1] + XS / 2, role="path", colour=ASPHALT,
           cost=1.0, reflectance=0.3)
    nodes = {"x_club": b.node("x_club", *xc, "intersection", obj="int_club")}
    for nid, (x, y) in {"start": (0.0, 0.0), "green": (220.0, 110.0), "clubhouse": (220.0, -80.0), "east_gate": (310.0, 0.0)}.items():
        nodes[nid] = b.node(nid, x, y, "place", name=nid)

    def double_yellow(centre, dash_from: float | None = None, dash_to: float | None = None) -> list[Marking]:
        if dash_from is None:
            return [Marking(colour="yellow", line=tuple(_offset_line(centre, d)), width=0.1) for d in (-0.12, 0.12)]
        out = []
        for a, c in ((-1e4, dash_from), (dash_to, 1e4)):
            part = _clip_line(centre, a, c)
            out += [Marking(colour="yellow", line=tuple(_offset_line(part, d)), width=0.1) for d in (-0.12, 0.12)]
        out.append(Marking(colour="yellow", line=tuple(_clip_line(centre, dash_from, dash_to)), width=0.1, dash=(3.0, 9.0)))
        return out

    def road(eid: str, a: str, c: str, via=(), markings_for=None, name: str | None = None):
        na, nc = nodes[a], nodes[c]
        pts = [np.array([na.x, na.y]), *[np.array(v, dtype=float) for v in via], np.array([nc.x, nc.y])]
        for end in (0, -1):
            n = na if end == 0 else nc
            if n.node_kind == "intersection":
                nb = pts[1] if end == 0 else pts[-2]
                u = nb - pts[end]
                pts[end] = pts[end] + u / np.linalg.norm(u) * XS / 2
        centre = [(round(float(p[0]), 3), round(float(p[1]), 3)) for p in pts]
        marks = tuple(markings_for(centre)) if markings_for else ()
        r = b.strip(f"road_{eid}", "road", centre, RW, role="path", colour=ASPHALT, cost=1.0, reflectance=0.3, markings=marks, name=name)
        b.edge(f"e_{eid}", na, nc, mode="follow-road", objs=(r.id,), width=RW, via=via)
        return centre

    def plain(centre) -> list[Marking]:
        return [*double_yellow(centre), *(Marking(colour="white", line=tuple(_offset_line(centre, d)), width=0.12) for d in (-EDGE, EDGE))]

    def golf_course_rd(centre) -> list[Marking]:
        out = double_yellow(centre, 55.0, 105.0)  # passing zone: one dashed yellow line
        out.append(Marking(colour="white", line=tuple(_offset_line(_clip_line(centre, -1e4, 110.0), EDGE)), width=0.12))
        out.append(Marking(colour="white", line=tuple(_offset_line(_clip_line(centre, 110.0, 165.0), EDGE)), width=0.12, dash=(3.0, 3.0)))
        out.append(Marking(colour="white", line=tuple(_offset_line(_clip_line(centre, 165.0, 1e4), EDGE)), width=0.12))
        # south edge: solid to the taper, then out along the added lane; a dashed lane line carries on
        out.append(Marking(colour="white", line=tuple(_offset_line(_clip_line(centre, -1e4, 165.0), -EDGE)), width=0.12))
        out.append(Marking(colour="white", line=((165.0, -EDGE), (177.0, -EDGE - 3.5), (214.0, -EDGE - 3.5)), width=0.12))
        out.append(Marking(colour="white", line=((165.0, -EDGE), (214.0, -EDGE)), width=0.12, dash=(3.0, 9.0)))
        return out

    # Golf Course Rd: a bend 10 m north and back between x = 25 and 155 (radius >= 85 m), straight to the intersection
    bend = [(round(float(x), 3), round(float(10.0 * math.sin(math.pi * (x - 25.0) / 130.0) ** 2), 3))
            for x in np.linspace(30.0, 150.0, 25)]
    bend = [(25.0, 0.0), *bend, (155.0, 0.0)]
    road("golf", "start", "x_club", via=bend, markings_for=golf_course_rd, name="Golf Course Rd")
    # the added right-turn lane (south side), tapering in over 12 m
    b.area("road_turn_lane", "road", [(165.0, -RW / 2), (214.0, -RW / 2), (214.0, -RW / 2 - 3.5), (177.0, -RW / 2 - 3.5)],
           role="path", colour=ASPHALT, cost=1.0, reflectance=0.3)
    road("tee_n", "x_club", "green", markings_for=plain, name="Tee Dr")
    road("tee_s", "x_club", "clubhouse", markings_for=plain, name="Tee Dr")
    road("east", "x_club", "east_gate", markings_for=plain, name="East Dr")

    # trees: a row south of Golf Course Rd (shadows fall north across it), a few north of it and along Tee Dr
    for i, x in enumerate(np.arange(8.0, 205.0, 11.0)):
        yc = 10.0 * math.sin(math.pi * (x - 25.0) / 130.0) ** 2 if 25.0 <= x <= 155.0 else 0.0
        side = -1.0 if i % 4 != 3 else 1.0
        d = RW / 2 + 3.0 + float(rng.uniform(0.0, 3.0)) + (3.5 if (side < 0 and x > 160.0) else 0.0)
        b.tree(f"tree_gc{i:02d}", float(x + rng.uniform(-2.0, 2.0)), yc + side * d, rng, scale=1.15)
    for i, y in enumerate(np.arange(16.0, 105.0, 13.0)):
        b.tree(f"tree_tee{i:02d}", 220.0 - RW / 2 - 3.5 - float(rng.uniform(0.0, 2.5)), float(y), rng, scale=1.1)
    b.rect("clubhouse_bldg", "building", 236.0, -70.0, 256.0, -52.0, role="landmark", colour=BRICK, shape=PrismShape(height=7.0),
           name="clubhouse", reflectance=0.5)
    b.rect("bunker_7", "driveway", 120.0, 30.0, 134.0, 38.0, role="none", colour=BUFF, cost=5.0, reflectance=0.5)
    b.round_obj("sign_club", "sign", xc[0] - XS / 2 - 1.5, xc[1] + XS / 2 + 1.5, 0.08, role="landmark", colour=RED,
                shape=PostShape(height=2.4), name="stop sign", reflectance=0.9)
    b.keep_clear(("road", "intersection"), ROADSIDE_CLEARANCE)
    return b.world(sun=Sun(azimuth_deg=200.0, elevation_deg=38.0), start=StartPose(x=0.0, y=0.0, yaw_deg=0.0, node="start"),
                   weather=Weather(wet_cover=0.05, leaf_cover=0.02, period_s=360.0))


WORLD_BUILDERS = {"campus": build_campus, "north_hills": build_north_hills, "schenley": build_schenley}


def write_worlds(out_dir: Path = WORLDS_DIR) -> list[Path]:
    """Build every world, validate it, and write `<name>.world.geojson` and `<name>.map.geojson` to `out_dir`."""
    from vehicle_sim.mapgen import map_for
    from vehicle_sim.worldfile import load_world

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name, build in WORLD_BUILDERS.items():
        w = build()
        p = w.save(out_dir / f"{name}.world.geojson")
        w = load_world(p)  # re-validate the written file
        m = map_for(w, 1.0, 0)
        written += [p, m.save(out_dir / f"{name}.map.geojson")]
    return written


def main() -> None:
    """Regenerate the shipped world and map files."""
    for p in write_worlds():
        print(p)


if __name__ == "__main__":
    main()
