"""`sidewalk terrain eval`: the elevation maps of ERIM images (buckets, the locus method) scored against the truth raster.

The vehicle drives a feasible track on the truth (`vehicle_sim.generated.corridor`) from the world's
start, `images` ERIM images `spacing` [m] apart. For each image the robot's side gets what it would
have: the capture without truth (the ranges, and its inclinometer's roll and pitch), and a pose
estimate (the true x, y, yaw plus the `pose_noise` errors drawn from the seed). Its height is what
the robot can know: the first image's from the truth (the map's datum), each later one's from the
fused map under the vehicle's origin (its wheels are on that ground), and every image's map is then
registered in z by the mean difference (Navlab 1990 §2.3.3) before it is fused.

Scored (truth, here only): each image's bucket and locus maps, and the two fused maps, against the
true ground height at the cell centres, over the cells the map knows (`rms_m`, `p95_m`) and over those
within `within` [m] of the sensor (`rms_within_m`, `p95_within_m`); cells under a tree's or a bush's
crown are left out (the maps see the crown there). Of the cells **in view** within `within` (inside
the scanner's field of view as truly posed, within its 40 m range): the share the map knows
(`known_share`), and of those it marks unknown the share truly in a range shadow (`unknown_shadowed_share`):
the line from the true laser origin to the cell's true ground (2 cm above it) meets a surface more
than 10 cm before it (the simulator's own ray caster); `unknown_near_shadow_share` counts too the cells whose line of
sight clears the true ground by less than one pixel's vertical pitch times the distance there (at the scanner's angular
sampling they cannot be told from a shadow: the ground beyond a crest seen at grazing incidence). `update_ms_p50`: the robot's update per image
(unwrap, map, z registration, fusion) [ms] wall, with its process CPU time beside it.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass

import numpy as np

from sidewalk.errors import SidewalkError
from modules.terrain.bucket_map import bucket_map
from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.fusion import fuse
from modules.terrain.grid_spec import GridSpec
from modules.terrain.locus import LocusParams, locus_map
from modules.terrain.range_image import RangeImage
from modules.terrain.vehicle_pose import VehiclePose
from vehicle_sim.generated.corridor import find_corridor
from vehicle_sim.scene import Scene
from vehicle_sim.sensors.capture import capture
from vehicle_sim.worldfile import TreeShape, World
from wire.capture import CaptureRequest, without_truth
from wire.summary import percentile

__all__ = ["TerrainEvalConfig", "TerrainEvalError", "evaluate", "track_poses"]


class TerrainEvalError(SidewalkError, ValueError):
    """The evaluation cannot run on this world (no terrain, no track); the message says why."""


@dataclass(frozen=True)
class TerrainEvalConfig:
    """How the evaluation drives and maps: images and their spacing [m], the map's cell [m], reach [m], errors, seed."""

    images: int = 12
    spacing_m: float = 2.0
    resolution_m: float = 0.1
    within_m: float = 20.0
    max_range_m: float = 20.0
    vehicle: str = "navlab"
    pose_noise: tuple[float, float] = (0.0, 0.0)  # x/y sigma [m], yaw sigma [deg] of the pose estimate
    seed: int = 0
    shadow_tolerance_m: float = 0.10


def track_poses(world: World, cfg: TerrainEvalConfig) -> np.ndarray:
    """Return `cfg.images` poses (K, 3) [m, m, rad], `spacing_m` apart along a feasible track from the world's start."""
    if world.start is None:
        raise TerrainEvalError(f"world {world.name!r} has no start pose")
    s = world.start
    length = cfg.spacing_m * (cfg.images - 1)
    goal = (s.x + (length + 4.0) * math.cos(s.yaw), s.y + (length + 4.0) * math.sin(s.yaw))
    track = find_corridor(world, (s.x, s.y, s.yaw), goal, vehicle=cfg.vehicle, reach=2.0)
    if track is None:
        raise TerrainEvalError(f"no feasible track {length:.0f} m long from the start of {world.name!r}")
    step = np.hypot(*np.diff(track[:, :2], axis=0).T)
    along = np.concatenate([[0.0], np.cumsum(step)])
    at = np.minimum(np.arange(cfg.images) * cfg.spacing_m, along[-1])
    x = np.interp(at, along, track[:, 0])
    y = np.interp(at, along, track[:, 1])
    yaw = np.interp(at, along, np.unwrap(track[:, 2]))
    return np.column_stack([x, y, yaw])


def _crowns(world: World, spec: GridSpec) -> np.ndarray:
    """Return (ny, nx) bool: cells under a tree's or bush's crown."""
    cx, cy = spec.centres()
    out = np.zeros(spec.shape, bool)
    for o in world.objects:
        if isinstance(o.shape, TreeShape) and o.center is not None:
            r = o.shape.crown_radius + spec.resolution
            j = (cx >= o.center[0] - r) & (cx <= o.center[0] + r)
            i = (cy >= o.center[1] - r) & (cy <= o.center[1] + r)
            if j.any() and i.any():
                sub = np.hypot(cx[j][None, :] - o.center[0], cy[i][:, None] - o.center[1]) <= r
                out[np.ix_(i, j)] |= sub
    return out


@dataclass
class _Scores:
    errors: list
    errors_within: list
    in_view: int = 0
    known_in_view: int = 0
    unknown_in_view: int = 0
    shadowed: int = 0
    near_shadow: int = 0

    def add(self, grid: ElevationGrid, truth: np.ndarray, usable: np.ndarray, near: np.ndarray) -> None:
        k = grid.known & usable
        e = (grid.z.astype(np.float64) - truth)[k]
        self.errors.append(e)
        self.errors_within.append((grid.z.astype(np.float64) - truth)[k & near])

    def summary(self) -> dict:
        def stats(parts: list) -> tuple[float | None, float | None, int]:
            e = np.concatenate(parts) if parts else np.zeros(0)
            if not len(e):
                return None, None, 0
            return round(float(np.sqrt(np.mean(e * e))), 4), percentile(np.abs(e), 95, digits=4), int(len(e))
        rms, p95, n = stats(self.errors)
        rms_w, p95_w, n_w = stats(self.errors_within)
        out = {"rms_m": rms, "p95_m": p95, "cells": n, "rms_within_m": rms_w, "p95_within_m": p95_w, "cells_within": n_w}
        if self.in_view:
            out["known_share"] = round(self.known_in_view / self.in_view, 4)
            out["unknown_shadowed_share"] = round(self.shadowed / self.unknown_in_view, 4) if self.unknown_in_view else None
            out["unknown_near_shadow_share"] = round(self.near_shadow / self.unknown_in_view, 4) if self.unknown_in_view else None
            out["unknown_cells"] = self.unknown_in_view
        return out


def _in_view(cap, truth_z: np.ndarray, spec: GridSpec, within: float) -> np.ndarray:
    """Return (ny, nx) bool: the cell's true ground lies in the scanner's field of view (as truly posed), within `within` [m]."""
    cx, cy = spec.centres()
    X, Y = np.meshgrid(cx, cy)
    P = np.stack([X, Y, truth_z], -1)
    T = np.asarray(cap.truth_world_laser)
    q = (P - T[:3, 3]) @ T[:3, :3]
    az = np.arctan2(q[..., 1], q[..., 0])
    el = np.arctan2(q[..., 2], np.hypot(q[..., 0], q[..., 1]))
    laz, lel = cap.laser_az.astype(np.float64), cap.laser_el.astype(np.float64)
    horiz = np.hypot(X - T[0, 3], Y - T[1, 3])
    return ((az >= laz.min()) & (az <= laz.max()) & (el >= lel.min()) & (el <= lel.max()) & (horiz <= within)
            & (np.linalg.norm(q, axis=-1) <= 40.0))


def _shadowed(scene: Scene, cap, cells: tuple[np.ndarray, np.ndarray], truth_z: np.ndarray, spec: GridSpec, tol: float,
              pitch: float) -> tuple[int, int]:
    """Return how many of the cells (rows, cols) are truly in a range shadow from the true laser origin, and how many are
    in one or in a near shadow (`_grazing`)."""
    if len(cells[0]) == 0:
        return 0, 0
    cx, cy = spec.centres()
    P = np.column_stack([cx[cells[1]], cy[cells[0]], truth_z[cells] + 0.02])
    o = np.asarray(cap.truth_world_laser)[:3, 3]
    d = P - o
    hits = scene.cast_rays(o, d, reach=float(np.hypot(d[:, 0], d[:, 1]).max()) + 1.0)
    dist = np.linalg.norm(d, axis=1)
    blocked = hits.rng.astype(np.float64) < dist - tol
    return int(blocked.sum()), int((blocked | _grazing(scene.world, o, P, pitch)).sum())


def _grazing(world: World, o: np.ndarray, P: np.ndarray, pitch: float, samples: int = 161, chunk: int = 2048) -> np.ndarray:
    """Return (N,) bool: the line of sight from `o` (3,) to each point of `P` (N, 3) [m] clears the true ground by less
    than one pixel's vertical pitch `pitch` [rad] times its distance (the scanner cannot tell it from a shadow), away
    from both ends (1 m from the sensor, 0.3 m from the point)."""
    out = np.zeros(len(P), bool)
    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    for a in range(0, len(P), chunk):
        q = P[a:a + chunk]
        line = o[None, None] + t * (q - o)[:, None, :]
        ground = world.elevation(line[..., :2].reshape(-1, 2)).reshape(line.shape[:2])
        r = np.linalg.norm(line - o, axis=-1)
        inside = (np.linalg.norm(line - q[:, None, :], axis=-1) > 0.3) & (r > 1.0)
        out[a:a + chunk] = np.any(inside & (line[..., 2] - ground < r * pitch), axis=1)
    return out


def evaluate(world: World, cfg: TerrainEvalConfig = TerrainEvalConfig()) -> dict:
    """Return the evaluation's figures (a JSON-ready dict) for `world`, which must have terrain."""
    if world.terrain_raster is None:
        raise TerrainEvalError(f"world {world.name!r} has no terrain (a world file with a 'terrain' entry is needed)")
    poses = track_poses(world, cfg)
    scene = Scene(world, seed=cfg.seed)
    rng = np.random.default_rng([cfg.seed, 0x7E44])
    specs = [GridSpec.around(float(x), float(y), float(yaw), ahead=cfg.max_range_m + 1.0, behind=1.0,
                             side=cfg.max_range_m + 1.0, resolution=cfg.resolution_m) for x, y, yaw in poses]
    res = cfg.resolution_m
    i0, j0 = min(round(s.origin_y / res) for s in specs), min(round(s.origin_x / res) for s in specs)
    i1, j1 = max(round(s.origin_y / res) + s.ny for s in specs), max(round(s.origin_x / res) + s.nx for s in specs)
    region = GridSpec(j0 * res, i0 * res, res, i1 - i0, j1 - j0)  # every image's window, on one lattice
    rcx, rcy = region.centres()
    RX, RY = np.meshgrid(rcx, rcy)
    truth_region = world.elevation(np.column_stack([RX.ravel(), RY.ravel()])).reshape(region.shape)
    usable_region = ~_crowns(world, region)
    fused = {"locus": region.unknown(), "bucket": region.unknown()}
    scores = {"locus": _Scores([], []), "bucket": _Scores([], [])}
    wall = {"locus": [], "bucket": []}
    cpu = {"locus": [], "bucket": []}
    params = LocusParams(max_range=cfg.max_range_m)
    z_est: dict[str, float] = {}
    for k, (x, y, yaw) in enumerate(poses):
        cap = capture(scene, (float(x), float(y), float(yaw)), float(k), CaptureRequest(camera=False), vehicle=cfg.vehicle,
                      rng=np.random.default_rng([cfg.seed, k]))
        robot = without_truth(cap)
        spec = specs[k]
        di, dj = spec.offset_in(region)
        rows, cols = slice(di, di + spec.ny), slice(dj, dj + spec.nx)
        truth, usable = truth_region[rows, cols], usable_region[rows, cols]
        view = _in_view(cap, truth, spec, cfg.within_m)
        cx, cy = spec.centres()
        near = np.hypot(*np.meshgrid(cx - x, cy - y)) <= cfg.within_m
        ex, ey = rng.normal(0.0, cfg.pose_noise[0], 2)
        eyaw = math.radians(rng.normal(0.0, cfg.pose_noise[1]))
        for method in ("locus", "bucket"):
            t0, c0 = time.perf_counter(), time.process_time()
            image = RangeImage.from_capture(robot)
            acc = fused[method]
            px, py, pyaw = float(x) + ex, float(y) + ey, float(yaw) + eyaw
            if k == 0:
                z0 = float(cap.truth_z)  # the datum: the first image's height from the truth
            else:  # the ground the fused map holds under the vehicle's origin, else the last image's height
                i = int(math.floor((py - region.origin_y) / region.resolution))
                j = int(math.floor((px - region.origin_x) / region.resolution))
                under = acc.z[max(i - 2, 0):i + 3, max(j - 2, 0):j + 3]
                z0 = float(np.nanmean(under)) if np.isfinite(under).any() else z_est[method]
            pose = VehiclePose(px, py, z0, float(robot.attitude[0]), float(robot.attitude[1]), pyaw)
            Tv = pose.world_from_vehicle()
            grid = locus_map(image, Tv, spec, params) if method == "locus" else bucket_map(image, Tv, spec,
                                                                                            max_range=cfg.max_range_m)
            merged, off = fuse(spec.take(acc), grid, register_z=k > 0)
            wall[method].append((time.perf_counter() - t0) * 1e3)
            cpu[method].append((time.process_time() - c0) * 1e3)
            fused[method] = _put(acc, merged, di, dj)  # the evaluation's record of the whole drive (not the robot's work)
            z_est[method] = z0 + off.dz
            registered = ElevationGrid(grid.origin_x, grid.origin_y, grid.resolution, grid.z + np.float32(off.dz), grid.sigma,
                                       grid.frame)
            sc = scores[method]
            sc.add(registered, truth, usable, near)
            seen_view = view & usable
            sc.in_view += int(seen_view.sum())
            sc.known_in_view += int((seen_view & registered.known).sum())
            unknown = np.nonzero(seen_view & ~registered.known)
            sc.unknown_in_view += len(unknown[0])
            if method == "locus":
                blocked, near_shadow = _shadowed(scene, cap, unknown, truth, spec, cfg.shadow_tolerance_m,
                                                 float(np.max(np.abs(np.diff(cap.laser_el.astype(np.float64))))))
                sc.shadowed += blocked
                sc.near_shadow += near_shadow
    out: dict = {"world": world.name, "vehicle": cfg.vehicle, "images": len(poses), "spacing_m": cfg.spacing_m,
                 "resolution_m": cfg.resolution_m, "within_m": cfg.within_m, "max_range_m": cfg.max_range_m,
                 "pose_noise": list(cfg.pose_noise), "seed": cfg.seed, "load_avg_1min": round(os.getloadavg()[0], 2)}
    for method in ("locus", "bucket"):
        s = scores[method].summary()
        if method == "bucket":
            s.pop("unknown_shadowed_share", None)
            s.pop("unknown_near_shadow_share", None)  # not computed: a bucket map's holes are mostly sparse sampling
        s["update_ms_p50"] = round(float(np.median(wall[method])), 3)
        s["update_cpu_ms_p50"] = round(float(np.median(cpu[method])), 3)
        f = _Scores([], [])
        near_track = np.zeros(region.shape, bool)
        for x, y, _ in poses:
            near_track |= np.hypot(RX - x, RY - y) <= cfg.within_m
        f.add(fused[method], truth_region, usable_region, near_track)
        fs = f.summary()
        s["fused"] = {"rms_m": fs["rms_m"], "p95_m": fs["p95_m"], "cells": fs["cells"]}
        out[method] = s
    out["pyramid_build_ms"] = None  # the terrain pyramid (issue 40 part B) is not on this branch
    return out


def _put(acc: ElevationGrid, part: ElevationGrid, di: int, dj: int) -> ElevationGrid:
    """Return `acc` with the window `part` (rows di.., columns dj.. of `acc`) written in, clipped to `acc`."""
    z, s = acc.z.copy(), acc.sigma.copy()
    ny, nx = acc.shape
    py, px = part.shape
    i0, j0 = max(di, 0), max(dj, 0)
    i1, j1 = min(di + py, ny), min(dj + px, nx)
    if i1 > i0 and j1 > j0:
        z[i0:i1, j0:j1] = part.z[i0 - di:i1 - di, j0 - dj:j1 - dj]
        s[i0:i1, j0:j1] = part.sigma[i0 - di:i1 - di, j0 - dj:j1 - dj]
    return ElevationGrid(acc.origin_x, acc.origin_y, acc.resolution, z, s, acc.frame)
