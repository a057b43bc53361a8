"""Derive the map (what the robot is told) from the world (the truth) with a configurable error."""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.worldfile import (
    PathEdge,
    PathNode,
    SlopeShape,
    StairsShape,
    StartPose,
    World,
    WorldObject,
)

__all__ = [
    "MapError", "DEFAULT_MAP_ERROR", "NO_MAP_ERROR", "derive_map", "map_for", "REMOVABLE_ROLES",
    "map_with_error", "MISSING_PER_M", "MISSING_MAX",
]

#: Roles of objects that may be displaced or left out of the map (path objects never are).
REMOVABLE_ROLES = ("landmark", "obstacle")


class MapError(BaseModel):
    """How wrong the map is: a rigid offset [m] and rotation [deg] about the start, per-object errors.

    `displace_std` [m] is the per-axis standard deviation of independent displacements of landmark and
    obstacle objects, each displacement clipped to `displace_max` [m] when given; `missing_fraction` is
    the probability that such an object is absent from the map.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    offset_x: float = 0.0
    offset_y: float = 0.0
    rotation_deg: float = 0.0
    displace_std: float = Field(default=0.0, ge=0.0)
    displace_max: float | None = Field(default=None, ge=0.0)
    missing_fraction: float = Field(default=0.0, ge=0.0, le=1.0)

    @classmethod
    def scaled(cls, magnitude: float) -> "MapError":
        """Return the default error scaled by `magnitude` (0 = perfect map, 1 = default)."""
        d = DEFAULT_MAP_ERROR
        return cls(
            offset_x=d.offset_x * magnitude,
            offset_y=d.offset_y * magnitude,
            rotation_deg=d.rotation_deg * magnitude,
            displace_std=d.displace_std * magnitude,
            missing_fraction=min(1.0, d.missing_fraction * magnitude),
        )


#: The small error shipped maps carry: 0.4 m offset, 0.3° rotation, 0.25 m object scatter, 5 % missing.
DEFAULT_MAP_ERROR = MapError(offset_x=0.3, offset_y=-0.25, rotation_deg=0.3, displace_std=0.25, missing_fraction=0.05)
NO_MAP_ERROR = MapError()


def derive_map(world: World, error: MapError, rng: np.random.Generator) -> World:
    """Return a map of `world`: rigidly moved by the offset/rotation about the start, objects scattered and dropped.

    Geometry stays in the `world` frame; the randomness comes only from `rng`.
    """
    if world.start is not None:
        pivot = np.array([world.start.x, world.start.y])
    else:
        xmin, ymin, xmax, ymax = world.bounds()
        pivot = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])
    th = math.radians(error.rotation_deg)
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    t = np.array([error.offset_x, error.offset_y])

    def move(p: np.ndarray) -> np.ndarray:
        return (np.asarray(p, float) - pivot) @ R.T + pivot + t

    def tup(a: np.ndarray) -> tuple[tuple[float, float], ...]:
        return tuple((round(float(x), 4), round(float(y), 4)) for x, y in a.reshape(-1, 2))

    objects: list[WorldObject] = []
    for o in world.objects:
        removable = o.role in REMOVABLE_ROLES
        # draw both numbers for every object so the stream does not depend on earlier outcomes
        drop = rng.random() < error.missing_fraction
        d = rng.normal(0.0, 1.0, size=2) * error.displace_std
        if error.displace_max is not None and (n := float(np.hypot(*d))) > error.displace_max:
            d *= error.displace_max / n
        if removable and drop:
            continue
        shift = d if removable else np.zeros(2)
        update: dict = {}
        if o.polygon is not None:
            update["polygon"] = tup(move(np.asarray(o.polygon)) + shift)
        else:
            update["center"] = tup(move(np.asarray(o.center)) + shift)[0]
        update["appearance"] = None  # a map states colour type and nominal colour, never how the surface looks
        update["markings"] = ()
        if isinstance(o.shape, (SlopeShape, StairsShape)) and error.rotation_deg:
            update["shape"] = o.shape.model_copy(update={"axis_deg": o.shape.axis_deg + error.rotation_deg})
        # build a fresh object (model_copy would carry cached geometry of the original over)
        objects.append(WorldObject(**{**{f: getattr(o, f) for f in WorldObject.model_fields}, **update}))
    nodes: list[PathNode] = []
    for n in world.nodes:
        x, y = move(np.array([n.x, n.y]))
        nodes.append(n.model_copy(update={"x": round(float(x), 4), "y": round(float(y), 4)}))
    edges: list[PathEdge] = []
    for e in world.edges:
        edges.append(e.model_copy(update={"coords": tup(move(np.asarray(e.coords)))}))
    start = None
    if world.start is not None:
        sx, sy = move(np.array([world.start.x, world.start.y]))
        start = StartPose(x=round(float(sx), 4), y=round(float(sy), 4), yaw_deg=world.start.yaw_deg + error.rotation_deg, node=world.start.node)
    return World(name=world.name, objects=objects, nodes=nodes, edges=edges, sun=world.sun, start=start,
                 source=f"<map of {world.source}>", raster_res=world.raster_res)


def map_for(world: World, scale: float = 1.0, seed: int = 0) -> World:
    """Return the map of `world` with the default error scaled by `scale`, drawn from `seed`.

    The shipped `<name>.map.geojson` files are `map_for(world, 1.0, 0)`; so is what `sim serve` serves by default.
    """
    return derive_map(world, MapError.scaled(scale), np.random.default_rng(seed))


#: Fraction of landmark and obstacle objects `map_with_error` leaves out per metre of error [1/m].
MISSING_PER_M = 0.1
#: The most `map_with_error` ever leaves out (a fraction of the landmark and obstacle objects).
MISSING_MAX = 0.2
# How the unit error (before scaling) splits: rigid offset, rotation at the farthest vertex, vertex scatter [m].
_UNIT_OFFSET, _UNIT_ROTATION, _UNIT_SCATTER_STD, _UNIT_SCATTER_MAX = 0.4, 0.3, 0.15, 0.45
# A vertex moves at most this fraction of its polygon's clearance, so every polygon stays valid.
_CLEARANCE_SHARE = 0.45


def map_with_error(world: World, max_m: float, rng: np.random.Generator) -> World:
    """Return a map of `world` whose largest vertex displacement from the truth is `max_m` [m].

    The error is what real maps get wrong: a rigid offset and a rotation about the start, every
    vertex scattered (objects of every role, path-graph nodes and edges; a position shared by
    several features moves once, so neighbouring areas stay joined; an edge's ends move with its
    nodes) and missing landmark and obstacle objects (`MISSING_PER_M` of them per metre of `max_m`,
    at most `MISSING_MAX`). One unit draw of all of it is scaled until the largest displacement of
    any vertex kept in the map (the start pose included) is `max_m`. A vertex moves at most 45 % of
    its polygon's clearance (the distance from a vertex to the nearest other side), so thin walls
    keep a valid outline. Like every map it states no appearance, markings, weather or actors (world-only).
    Geometry stays in the `world` frame; randomness comes only from `rng`.
    """
    if not (max_m >= 0.0 and math.isfinite(max_m)):
        raise ValueError(f"map error must be a finite distance >= 0 [m], got {max_m!r}")
    drop_p = min(MISSING_MAX, MISSING_PER_M * max_m)
    dropped = {o.id for o in world.objects if rng.random() < drop_p and o.role in REMOVABLE_ROLES}
    kept = [o for o in world.objects if o.id not in dropped]
    pivot = _pivot(world)
    unit = _UnitError.draw(world, kept, pivot, rng)
    k = unit.scale_for(max_m)
    return unit.apply(world, kept, k, dropped)


def _pivot(world: World) -> np.ndarray:
    if world.start is not None:
        return np.array([world.start.x, world.start.y])
    xmin, ymin, xmax, ymax = world.bounds()
    return np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])


def _corners(o: WorldObject) -> np.ndarray:
    """Return the vertices the map file gives an object: its polygon (M,2), or its centre (1,2) [m]."""
    return np.asarray(o.polygon if o.polygon is not None else (o.center,), dtype=float)


def _key(p: np.ndarray) -> tuple[int, int]:
    """Return a position rounded to 1 cm: features sharing it share one scatter draw."""
    return (int(round(float(p[0]) * 100)), int(round(float(p[1]) * 100)))


def _clearance(v: np.ndarray) -> float:
    """Return the smallest distance from a vertex of ring `v` (M,2) to a side not touching it [m]."""
    import shapely

    m = len(v)
    best = math.inf
    for i in range(m):
        p = shapely.Point(v[i])
        for j in range(m):
            if j == i or (j + 1) % m == i:
                continue
            best = min(best, shapely.LineString([v[j], v[(j + 1) % m]]).distance(p))
    return best


class _UnitError:
    """One draw of every part of a map error at unit scale: offset, rotation, per-position scatter."""

    def __init__(self, pivot: np.ndarray, offset: np.ndarray, rotation: float, scatter: dict, cap: dict, points: np.ndarray) -> None:
        self.pivot = pivot
        self.offset = offset  # [m] at k = 1
        self.rotation = rotation  # [rad] at k = 1
        self.scatter = scatter  # position key → (2,) [m] at k = 1
        self.cap = cap  # position key → largest scatter [m]
        self.points = points  # (N,2) every vertex kept in the map [m]
        self._keys = [_key(p) for p in points]

    @classmethod
    def draw(cls, world: World, kept: list[WorldObject], pivot: np.ndarray, rng: np.random.Generator) -> "_UnitError":
        pts: list[np.ndarray] = []
        cap: dict[tuple[int, int], float] = {}
        for o in kept:
            v = _corners(o)
            pts.append(v)
            c = _CLEARANCE_SHARE * _clearance(v) if o.polygon is not None and len(v) >= 3 else math.inf
            for p in v:
                cap[_key(p)] = min(cap.get(_key(p), math.inf), c)
        pts += [np.array([[n.x, n.y]]) for n in world.nodes]
        pts += [np.asarray(e.coords[1:-1], float).reshape(-1, 2) for e in world.edges]
        if world.start is not None:
            pts.append(np.array([[world.start.x, world.start.y]]))
        points = np.vstack(pts)
        r_max = max(1.0, float(np.max(np.hypot(*(points - pivot).T))))
        bearing = rng.uniform(0.0, 2.0 * math.pi)
        offset = _UNIT_OFFSET * np.array([math.cos(bearing), math.sin(bearing)])
        rotation = (1.0 if rng.random() < 0.5 else -1.0) * _UNIT_ROTATION / r_max
        scatter: dict[tuple[int, int], np.ndarray] = {}
        for p in points:
            key = _key(p)
            if key not in scatter:
                d = rng.normal(0.0, _UNIT_SCATTER_STD, size=2)
                if (n := float(np.hypot(*d))) > _UNIT_SCATTER_MAX:
                    d *= _UNIT_SCATTER_MAX / n
                scatter[key] = d
        return cls(pivot, offset, rotation, scatter, cap, points)

    def move(self, p: np.ndarray, k: float, key_of: np.ndarray | None = None) -> np.ndarray:
        """Return positions `p` (N,2) [m] under the error scaled by `k`; scatter drawn at `key_of` (default `p`)."""
        p = np.asarray(p, float).reshape(-1, 2)
        th = k * self.rotation
        R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        out = (p - self.pivot) @ R.T + self.pivot + k * self.offset
        for i, q in enumerate(p if key_of is None else np.asarray(key_of, float).reshape(-1, 2)):
            key = _key(q)
            d = k * self.scatter[key]
            if (n := float(np.hypot(*d))) > (c := self.cap.get(key, math.inf)):
                d *= c / n
            out[i] += d
        return out

    def largest(self, k: float) -> float:
        """Return the largest displacement of any kept vertex under the error scaled by `k` [m]."""
        return float(np.max(np.hypot(*(self.move(self.points, k) - self.points).T))) if len(self.points) else 0.0

    def scale_for(self, max_m: float) -> float:
        """Return the scale at which the largest displacement is `max_m` [m] (bisection, 1 µm)."""
        if max_m == 0.0:
            return 0.0
        lo, hi = 0.0, 1.0
        while self.largest(hi) < max_m:
            lo, hi = hi, 2.0 * hi
        while hi - lo > 1e-9 * hi and self.largest(hi) - max_m > 1e-6:
            mid = 0.5 * (lo + hi)
            if self.largest(mid) < max_m:
                lo = mid
            else:
                hi = mid
        return hi

    def apply(self, world: World, kept: list[WorldObject], k: float, dropped: set[str]) -> World:
        def tup(a: np.ndarray) -> tuple[tuple[float, float], ...]:
            return tuple((round(float(x), 4), round(float(y), 4)) for x, y in a.reshape(-1, 2))

        rot_deg = math.degrees(k * self.rotation)
        objects = []
        for o in kept:
            update: dict = {}
            if o.polygon is not None:
                update["polygon"] = tup(self.move(_corners(o), k))
            else:
                update["center"] = tup(self.move(_corners(o), k))[0]
            if isinstance(o.shape, (SlopeShape, StairsShape)):
                update["shape"] = o.shape.model_copy(update={"axis_deg": o.shape.axis_deg + rot_deg})
            update["appearance"] = None  # a map states colour type and nominal colour, never how the surface looks
            update["markings"] = ()
            objects.append(WorldObject(**{**{f: getattr(o, f) for f in WorldObject.model_fields}, **update}))
        nodes, moved = [], {}
        for n in world.nodes:
            q = self.move(np.array([n.x, n.y]), k)[0]
            moved[n.id] = (q - np.array([n.x, n.y]))
            nodes.append(n.model_copy(update={"x": round(float(q[0]), 4), "y": round(float(q[1]), 4)}))
        edges = []
        for e in world.edges:
            c = np.asarray(e.coords, float)
            out = c.copy()
            out[1:-1] = self.move(c[1:-1], k) if len(c) > 2 else c[1:-1]
            out[0] = c[0] + moved[e.from_node]
            out[-1] = c[-1] + moved[e.to_node]
            edges.append(e.model_copy(update={"coords": tup(out)}))
        start = None
        if world.start is not None:
            s = self.move(np.array([world.start.x, world.start.y]), k)[0]
            start = StartPose(x=round(float(s[0]), 4), y=round(float(s[1]), 4), yaw_deg=world.start.yaw_deg + rot_deg, node=world.start.node)
        src = f"<map of {world.source}, largest vertex error {self.largest(k):.3f} m, {len(dropped)} objects left out>"
        return World(name=world.name, objects=objects, nodes=nodes, edges=edges, sun=world.sun, start=start,
                     source=src, raster_res=world.raster_res)
