"""A generated cross-country world (Navlab 1990 §2.3.3–2.4): rough ground, objects on it, a survey map, a mission across it.

From one seed: a strip of open country (a terrain raster at 0.1 m: rolling hills, ground roughness,
rocks, ditches, steps, a steep bank), trees and bushes standing on it, a start and a goal 200–400 m
apart with no road between, the map a robot would be given (a 10 m elevation grid like a survey
map, with its own error, and the objects a map would show: large trees and boulders, a little
displaced), and the mission (YAML) from the start to the goal. The generator checks its output: the
start and goal stand clear, and a corridor the vehicle can drive exists on the truth
(`generated.corridor.find_corridor`); a draw that fails is drawn again from the next sub-seed.
The same seed and parameters give identical files.

Frames: `world` (x east, y north, z up) [m]; the strip runs along +x.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field
from scipy.ndimage import gaussian_filter, map_coordinates

from wire.terrainfile import TerrainRaster, TerrainRef, quantise_terrain, save_terrain
from vehicle_sim.errors import SimError
from vehicle_sim.generated.corridor import find_corridor
from vehicle_sim.worldfile import StartPose, Sun, TreeShape, World, WorldObject
from vehicle_sim.worldgen import CROWN, GRASS, HEDGE, STONE, TRUNK, WorldBuilder

__all__ = ["CrossCountryParams", "CrossCountry", "CrossCountryError", "generate", "write"]


class CrossCountryError(SimError, ValueError):
    """The generator could not make a world whose goal is reachable (the message says what it tried)."""


class CrossCountryParams(BaseModel):
    """What a cross-country world is made of: sizes [m], feature counts and densities [per hectare], the map's error [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    distance_m: tuple[float, float] = (200.0, 400.0)  # start to goal, drawn in this range
    width_m: float = Field(80.0, ge=40.0)
    margin_m: float = Field(25.0, ge=10.0)  # beyond the start and the goal
    resolution_m: float = Field(0.1, gt=0.0, le=0.5)
    hills_m: tuple[float, float] = (2.5, 0.6)  # amplitude of hills 20 m and 8 m across
    rough_m: float = 0.05  # ground roughness about 1.5 m across
    grain_m: float = 0.012  # grain about 0.2 m across
    rocks_per_ha: float = 160.0
    trees_per_ha: float = 35.0
    bushes_per_ha: float = 55.0
    ditches: int = 4
    steps: int = 3
    banks: int = 1
    clear_m: float = 10.0  # nothing stands within this of the start and the goal
    map_grid_m: float = 10.0
    map_bias_m: float = 0.4  # the survey's datum error (a constant drawn within ±)
    map_error_m: float = 0.35  # the survey's smooth error, one sigma
    map_offset_m: float = 0.5  # the map objects' common offset
    map_scatter_m: float = 0.3  # each map object's own error, one sigma
    map_crown_m: float = 2.5  # trees with a crown this wide or wider are on the map
    map_boulder_m: float = 0.6  # rocks this wide (radius) or wider are on the map
    vehicle: str = "navlab"
    tolerance_m: float = 2.0  # the mission's goal tolerance
    attempts: int = Field(6, ge=1)


DEFAULT_PARAMS = CrossCountryParams()


@dataclass(frozen=True)
class CrossCountry:
    """One generated world: the world and its terrain (truth), the map and its terrain, the mission, the corridor found.

    `corridor` is the feasible track (K, 3) [m, m, rad] the generator proved on the truth (evaluation may use it).
    """

    name: str
    seed: int
    world: World
    terrain: TerrainRaster
    map: World
    map_terrain: TerrainRaster
    mission: dict
    corridor: np.ndarray


# ---------------------------------------------------------------------------------------------- terrain


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _noise(rng: np.random.Generator, shape: tuple[int, int], sigma_cells: float) -> np.ndarray:
    """Return smooth unit-std noise of `shape`, correlated over `sigma_cells`."""
    f = gaussian_filter(rng.standard_normal(shape), sigma_cells, mode="reflect")
    return f / max(float(f.std()), 1e-12)


def _upsample(coarse: np.ndarray, step: float, shape: tuple[int, int], res: float) -> np.ndarray:
    """Return `coarse` (samples `step` [m] apart) resampled at `res` [m] onto `shape`, cubic."""
    ny, nx = shape
    v = np.arange(ny) * (res / step)
    u = np.arange(nx) * (res / step)
    out = np.empty(shape, np.float32)
    rows = max(1, 400_000 // nx)
    for r0 in range(0, ny, rows):
        vv, uu = np.meshgrid(v[r0:r0 + rows], u, indexing="ij")
        out[r0:r0 + rows] = map_coordinates(coarse, [vv, uu], order=3, mode="nearest")
    return out


class _Raster:
    """The terrain heights being built, (ny, nx) float32 [m], with windowed edits in world coordinates."""

    def __init__(self, z: np.ndarray, res: float) -> None:
        self.z = z
        self.res = res

    def window(self, x0: float, y0: float, x1: float, y1: float) -> tuple[slice, slice, np.ndarray, np.ndarray]:
        """Return the row and column slices of the samples in [x0, x1] × [y0, y1] [m] and their coordinates (grids)."""
        ny, nx = self.z.shape
        j0, j1 = max(int(math.floor(x0 / self.res)), 0), min(int(math.ceil(x1 / self.res)) + 1, nx)
        i0, i1 = max(int(math.floor(y0 / self.res)), 0), min(int(math.ceil(y1 / self.res)) + 1, ny)
        ys, xs = np.meshgrid(np.arange(i0, i1) * self.res, np.arange(j0, j1) * self.res, indexing="ij")
        return slice(i0, i1), slice(j0, j1), xs, ys


def _rock(r: _Raster, x: float, y: float, radius: float, height: float) -> None:
    """Add a rock: a half-spheroid of `radius` and `height` [m] (steep sides, round top)."""
    rows, cols, xs, ys = r.window(x - radius, y - radius, x + radius, y + radius)
    q = 1.0 - ((xs - x) ** 2 + (ys - y) ** 2) / (radius * radius)
    r.z[rows, cols] += (height * np.sqrt(np.clip(q, 0.0, None))).astype(np.float32)


def _ditch(r: _Raster, a: np.ndarray, b: np.ndarray, width: float, depth: float) -> None:
    """Cut a ditch from `a` to `b` (2,) [m]: `width` across, `depth` deep, a cos² profile, rounded ends."""
    h = width / 2.0
    rows, cols, xs, ys = r.window(min(a[0], b[0]) - h, min(a[1], b[1]) - h, max(a[0], b[0]) + h, max(a[1], b[1]) + h)
    ab = b - a
    t = np.clip(((xs - a[0]) * ab[0] + (ys - a[1]) * ab[1]) / float(ab @ ab), 0.0, 1.0)
    d = np.hypot(xs - (a[0] + t * ab[0]), ys - (a[1] + t * ab[1]))
    r.z[rows, cols] -= (depth * np.where(d < h, np.cos(0.5 * np.pi * d / h) ** 2, 0.0)).astype(np.float32)


def _plateau(r: _Raster, cx: float, cy: float, angle: float, length: float, depth: float, height: float, front: float,
             ramp: float) -> None:
    """Raise a plateau `height` [m] with one steep front (rising over `front` [m]) and ramps of `ramp` [m] on its other sides.

    Its front edge, `length` [m] long, is centred on (cx, cy) [m]; the plateau lies `depth` [m] behind it, along `angle` [rad].
    """
    ext = length / 2.0 + depth + ramp + front
    rows, cols, xs, ys = r.window(cx - ext, cy - ext, cx + ext, cy + ext)
    c, s = math.cos(angle), math.sin(angle)
    u = (xs - cx) * c + (ys - cy) * s  # into the plateau
    v = -(xs - cx) * s + (ys - cy) * c  # along the front
    f = np.minimum(_smoothstep(u / front), np.clip((depth + ramp - u) / ramp, 0.0, 1.0))
    f = np.minimum(f, np.clip((length / 2.0 + ramp - np.abs(v)) / ramp, 0.0, 1.0))
    r.z[rows, cols] += (height * _smoothstep(f)).astype(np.float32)


def _clear_of(points: list[tuple[float, float]], x: float, y: float, d: float) -> bool:
    return all(math.hypot(x - px, y - py) >= d for px, py in points)


def _terrain(rng: np.random.Generator, p: CrossCountryParams, length: float, keep: list[tuple[float, float]]
             ) -> tuple[np.ndarray, list[tuple[float, float, float, float]], list[str]]:
    """Return the heights (ny, nx) float32 [m], the rocks (x, y, radius, height) [m] and a description of the features."""
    res = p.resolution_m
    shape = (int(round(p.width_m / res)) + 1, int(round(length / res)) + 1)
    coarse = (int(p.width_m / 2.0) + 3, int(length / 2.0) + 3)  # 2 m samples
    hills = p.hills_m[0] * _noise(rng, coarse, 10.0) + p.hills_m[1] * _noise(rng, coarse, 4.0)
    z = _upsample(hills, 2.0, shape, res)
    medium = (int(p.width_m / 0.5) + 3, int(length / 0.5) + 3)
    z += _upsample(p.rough_m * _noise(rng, medium, 3.0), 0.5, shape, res)
    z += (p.grain_m * _noise(rng, shape, 2.0)).astype(np.float32)
    r = _Raster(z, res)
    features = []
    clear = p.clear_m + 12.0

    def spot(margin: float) -> tuple[float, float]:
        for _ in range(200):
            x, y = float(rng.uniform(margin, length - margin)), float(rng.uniform(margin, p.width_m - margin))
            if _clear_of(keep, x, y, clear + margin):
                return x, y
        raise CrossCountryError("no room for a terrain feature away from the start and the goal")

    for k in range(p.banks):
        x, y = spot(15.0)
        angle, height = float(rng.uniform(0, 2 * math.pi)), float(rng.uniform(4.0, 6.0))
        _plateau(r, x, y, angle, float(rng.uniform(30.0, 50.0)), float(rng.uniform(12.0, 20.0)), height,
                 float(rng.uniform(3.5, 4.5)), 6.0 * height)
        features.append(f"bank {k}: {height:.1f} m at ({x:.0f}, {y:.0f})")
    for k in range(p.steps):
        x, y = spot(8.0)
        height = float(rng.uniform(0.3, 0.7))
        _plateau(r, x, y, float(rng.uniform(0, 2 * math.pi)), float(rng.uniform(8.0, 20.0)), float(rng.uniform(5.0, 10.0)),
                 height, 0.15, 8.0 * height)
        features.append(f"step {k}: {height:.2f} m at ({x:.0f}, {y:.0f})")
    for k in range(p.ditches):
        x, y = spot(12.0)
        angle, half = float(rng.uniform(0, np.pi)), float(rng.uniform(8.0, 20.0))
        d = np.array([math.cos(angle), math.sin(angle)])
        depth = float(rng.uniform(0.4, 1.0))
        _ditch(r, np.array([x, y]) - half * d, np.array([x, y]) + half * d, float(rng.uniform(1.2, 2.5)), depth)
        features.append(f"ditch {k}: {depth:.2f} m deep at ({x:.0f}, {y:.0f})")
    rocks = []
    n_rocks = int(round(p.rocks_per_ha * length * p.width_m / 1e4))
    for _ in range(n_rocks):
        x, y = float(rng.uniform(1.0, length - 1.0)), float(rng.uniform(1.0, p.width_m - 1.0))
        radius = float(np.clip(rng.lognormal(math.log(0.3), 0.5), 0.15, 1.0))
        height = radius * float(rng.uniform(0.5, 0.9))
        if not _clear_of(keep, x, y, p.clear_m):
            continue
        _rock(r, x, y, radius, height)
        rocks.append((x, y, radius, height))
    return r.z, rocks, features


# ---------------------------------------------------------------------------------------------- objects, map


def _survey(truth: TerrainRaster, p: CrossCountryParams, rng: np.random.Generator, length: float) -> TerrainRaster:
    """Return the map's elevation grid: the truth smoothed over a grid cell, sampled every `map_grid_m`, with its error."""
    g = p.map_grid_m
    smooth = gaussian_filter(truth.z.astype(np.float64), (g / 2.0) / truth.resolution, mode="nearest")
    ny, nx = int(math.ceil(p.width_m / g)) + 1, int(math.ceil(length / g)) + 1
    ys, xs = np.meshgrid(np.arange(ny) * g, np.arange(nx) * g, indexing="ij")
    sampled = map_coordinates(smooth, [ys / truth.resolution, xs / truth.resolution], order=1, mode="nearest")
    error = p.map_error_m * _noise(rng, (ny, nx), 4.0) + float(rng.uniform(-p.map_bias_m, p.map_bias_m))
    return TerrainRaster(0.0, 0.0, g, (sampled + error).astype(np.float32))


def _mapped(world_objects: list[WorldObject], p: CrossCountryParams, rng: np.random.Generator) -> list[WorldObject]:
    """Return the objects a map shows (large trees, boulders, the ground cover), as the map states them, displaced."""
    offset = rng.normal(0.0, 1.0, 2)
    offset *= p.map_offset_m / max(float(np.linalg.norm(offset)), 1e-9)
    out = []
    for o in world_objects:
        s = o.shape
        keep = (o.kind == "grass" or (isinstance(s, TreeShape) and s.crown_radius >= p.map_crown_m)
                or (o.kind == "rock" and float(np.ptp(o.vertices[:, 0])) / 2.0 >= p.map_boulder_m))
        if not keep:
            continue
        o = o.as_mapped()
        if o.kind != "grass":
            dx, dy = offset + rng.normal(0.0, p.map_scatter_m, 2)
            fields = {k: getattr(o, k) for k in WorldObject.model_fields}  # a new object: no cached outline
            if o.center is not None:
                fields["center"] = (round(float(o.center[0] + dx), 3), round(float(o.center[1] + dy), 3))
            else:
                fields["polygon"] = tuple((round(float(x + dx), 3), round(float(y + dy), 3)) for x, y in o.polygon or ())
            o = WorldObject(**fields)
        out.append(o)
    return out


def _draw(seed: int, attempt: int, p: CrossCountryParams, name: str) -> CrossCountry | None:
    rng = np.random.default_rng([seed, attempt, 0xC0C0])
    distance = float(rng.uniform(*p.distance_m))
    lateral = float(rng.uniform(-0.25, 0.25)) * p.width_m
    run = math.sqrt(max(distance * distance - lateral * lateral, 1.0))
    length = run + 2.0 * p.margin_m
    start = (p.margin_m, p.width_m / 2.0 - lateral / 2.0)
    goal = (p.margin_m + run, p.width_m / 2.0 + lateral / 2.0)
    heights, rocks, features = _terrain(rng, p, length, [start, goal])
    terrain, _ = quantise_terrain(TerrainRaster(0.0, 0.0, p.resolution_m, heights))  # as the file stores it: the truth
    b = WorldBuilder(name)
    b.rect("ground", "grass", 0.0, 0.0, length, p.width_m, role="none", colour=GRASS, cost=1.0, reflectance=0.45)
    ring = np.linspace(0.0, 2.0 * math.pi, 10, endpoint=False)
    for k, (x, y, radius, _h) in enumerate(rocks):  # the rock's outline (its shape is in the terrain)
        b.area(f"rock-{k}", "rock", np.column_stack([x + radius * np.cos(ring), y + radius * np.sin(ring)]), role="obstacle",
               colour=STONE, cost=math.inf, reflectance=0.5)
    keep = [start, goal]
    for kind, density in (("tree", p.trees_per_ha), ("bush", p.bushes_per_ha)):
        n = int(round(density * length * p.width_m / 1e4))
        for k in range(n):
            x, y = float(rng.uniform(1.0, length - 1.0)), float(rng.uniform(1.0, p.width_m - 1.0))
            if not _clear_of(keep, x, y, p.clear_m):
                continue
            if kind == "tree":
                h = float(rng.uniform(6.0, 14.0))
                crown, trunk = float(rng.uniform(1.5, 4.0)), float(rng.uniform(0.15, 0.4))
                shape = TreeShape(trunk_radius=round(trunk, 3), crown_radius=round(crown, 2), height=round(h, 2),
                                  crown_base=round(h * float(rng.uniform(0.3, 0.5)), 2), z0=-0.05)
                b.round_obj(f"tree-{k}", "tree", x, y, round(trunk, 3), role="obstacle", colour=TRUNK, shape=shape,
                            reflectance=0.35, crown=CROWN)
            else:  # a bush: a low crown on a thick woody base, an obstacle over most of its crown
                h = float(rng.uniform(0.8, 2.0))
                crown = float(rng.uniform(0.5, 1.3))
                base = round(0.6 * crown, 3)
                shape = TreeShape(trunk_radius=base, crown_radius=round(crown, 2), height=round(h, 2), crown_base=0.1, z0=-0.05)
                b.round_obj(f"bush-{k}", "tree", x, y, base, role="obstacle", colour=HEDGE, shape=shape, reflectance=0.4,
                            crown=CROWN)
    yaw = math.atan2(goal[1] - start[1], goal[0] - start[0])
    ref = TerrainRef(file=f"{name}.terrain.npz")
    world = World(name=name, objects=b.objects, sun=Sun(azimuth_deg=float(rng.uniform(120.0, 240.0)), elevation_deg=40.0),
                  start=StartPose(x=round(start[0], 3), y=round(start[1], 3), yaw_deg=round(math.degrees(yaw), 3)),
                  source=f"<generated:{name}>", terrain=ref, terrain_raster=terrain)
    corridor = find_corridor(world, (start[0], start[1], yaw), goal, vehicle=p.vehicle, reach=p.tolerance_m)
    if corridor is None:
        return None
    map_terrain = _survey(terrain, p, rng, length)
    mapped = World(name=name, objects=_mapped(list(b.objects), p, rng), sun=world.sun, start=world.start,
                   source=f"<generated:{name}.map>", terrain=TerrainRef(file=f"{name}.map-terrain.npz"),
                   terrain_raster=map_terrain)
    mission = {
        "mission": name, "description": f"cross country, {distance:.0f} m from the start to the goal with no road between "
                                        f"(seed {seed}; {'; '.join(features)})",
        "world": name, "vehicle": p.vehicle,
        "start": {"x": round(start[0], 3), "y": round(start[1], 3), "yaw_deg": round(math.degrees(yaw), 3)},
        "steps": [{"name": "to the goal", "destination": {"x": round(goal[0], 3), "y": round(goal[1], 3), "off_road": True},
                   "trigger": "stop", "tolerance": p.tolerance_m}],
    }
    return CrossCountry(name, seed, world, terrain, mapped, map_terrain, mission, corridor)


def generate(seed: int, params: CrossCountryParams = DEFAULT_PARAMS, *, name: str | None = None) -> CrossCountry:
    """Return the cross-country world of `seed`, checked (raise CrossCountryError when no draw had a feasible corridor)."""
    name = name or f"cross_country_{seed}"
    for attempt in range(params.attempts):
        out = _draw(seed, attempt, params, name)
        if out is not None:
            return out
    raise CrossCountryError(f"cross-country seed {seed}: no feasible corridor from the start to the goal in "
                            f"{params.attempts} draws; try another seed or fewer obstacles")


def write(world: CrossCountry, out: str | Path) -> list[Path]:
    """Write the world, its terrain, its map, the map's terrain and the mission into directory `out`; return the paths."""
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    n = world.name
    paths = [d / f"{n}.world.geojson", d / f"{n}.terrain.npz", d / f"{n}.map.geojson", d / f"{n}.map-terrain.npz", d / f"{n}.yaml"]
    world.world.save(paths[0])
    save_terrain(paths[1], world.terrain)
    world.map.save(paths[2])
    save_terrain(paths[3], world.map_terrain, quantum=None)
    named = "" if n == f"cross_country_{world.seed}" else f" --name {n}"
    paths[4].write_text(f"# generated by `sidewalk worldgen cross-country --seed {world.seed}{named}`\n"
                        + yaml.safe_dump(json.loads(json.dumps(world.mission)), sort_keys=False, allow_unicode=True))
    return paths
