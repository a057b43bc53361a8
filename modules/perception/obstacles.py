"""Obstacle detection from one laser range image (seed: Navlab 1990 §2.3.2).

Points go into the `vehicle` frame (x forward, y left, z up, origin on the ground), then into a
height map of square cells: per cell the highest point, and the ground is the lowest point of the
cell's neighbourhood. Cells standing more than `min_height` [m] above their ground are obstacle
cells; 8-connected groups of them become obstacles, each a convex polygon (`vehicle` frame) with a
height (`obstacles_from_points` runs the same on any range sensor's points, e.g. dense stereo's). `path_clear_distance` is the fast mode for emergency stop: only the points inside a corridor
along the planned path are looked at, and the first obstacle point along the path is returned.
Pure numpy; no blackboard, no truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.ndimage import label as cc_label
from scipy.ndimage import maximum_filter, minimum_filter

from modules.perception.patch_maker.range_seg import jump_edges, unwrap_range

__all__ = [
    "anchored_returns",
    "ObstacleConfig",
    "LaserScan",
    "Obstacle",
    "HeightMap",
    "scan_points",
    "unwrap_over_ground",
    "height_map",
    "detect_obstacles",
    "obstacles_from_points",
    "path_clear_distance",
    "path_in_vehicle",
]


class ObstacleConfig(BaseModel):
    """Height-map and detection settings: cell [m], extent [m], thresholds [m], minimum support."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    cell: float = Field(0.25, gt=0.0)
    x_max: float = Field(20.0, gt=0.0)  # forward extent of the map [m]
    y_half: float = Field(12.0, gt=0.0)  # lateral half-width [m]
    min_height: float = Field(0.3, gt=0.0)  # an obstacle stands this much above its ground [m]
    max_height: float = Field(3.0, gt=0.0)  # points higher above the vehicle's ground are overhead [m]
    ground_radius: int = Field(3, ge=1)  # neighbourhood half-size for the ground estimate [cells]
    min_points: int = Field(4, ge=1)  # an obstacle needs this many points
    max_horizontal: float = Field(20.0, gt=0.0)  # one ambiguity interval [m]


@dataclass(frozen=True)
class LaserScan:
    """One laser image: `range_m` (H, W) float32 wrapped range [m], `valid` (H, W) bool, ray angles [rad] in
    the `laser` frame (`az` (W,), `el` (H,)), `T_vehicle_laser` (4, 4) float64, `ambiguity` [m], `stamp` [s] sim."""

    range_m: np.ndarray
    valid: np.ndarray
    az: np.ndarray
    el: np.ndarray
    T_vehicle_laser: np.ndarray
    ambiguity: float
    stamp: float
    reflectance: np.ndarray | None = None  # (H, W) uint8 [DN]; gives each point's range noise

    @classmethod
    def from_capture(cls, c: object) -> "LaserScan":
        """Build from any object with the capture's laser fields (`wire.capture.CaptureResult`)."""
        return cls(range_m=c.laser_range, valid=c.laser_valid, az=c.laser_az, el=c.laser_el,  # type: ignore[attr-defined]
                   T_vehicle_laser=c.T_vehicle_laser, ambiguity=float(c.ambiguity), stamp=float(c.stamp),  # type: ignore[attr-defined]
                   reflectance=getattr(c, "laser_reflectance", None))


class Obstacle(BaseModel):
    """One obstacle in the `vehicle` frame: convex `polygon` [(x, y)] [m], `height` above its ground [m],
    `centroid` (x, y) [m], `distance` from the vehicle origin to the nearest point [m], `points` supporting it."""

    model_config = ConfigDict(frozen=True)

    polygon: tuple[tuple[float, float], ...]
    height: float
    centroid: tuple[float, float]
    distance: float
    points: int

    @property
    def size(self) -> float:
        """Return the polygon's largest extent [m]."""
        p = np.asarray(self.polygon)
        return float(np.max(np.linalg.norm(p[:, None] - p[None], axis=-1))) if len(p) > 1 else 0.0


@dataclass(frozen=True)
class HeightMap:
    """A height map over the `vehicle` frame: `top`, `ground` (R, C) float32 [m] (NaN = no point), `count` (R, C) int32;
    cell (i, j) covers x ∈ [i·cell, (i+1)·cell), y ∈ [−y_half + j·cell, …) [m]."""

    top: np.ndarray
    ground: np.ndarray
    count: np.ndarray
    cell: float
    y_half: float

    @property
    def height(self) -> np.ndarray:
        """Return (R, C) float32 height of each cell's top above its ground [m] (0 where empty)."""
        return np.nan_to_num(self.top - self.ground, nan=0.0)


#: the last scanner's ray directions: (azimuths, elevations, rotation) → (H, W, 3) unit vectors, `vehicle` frame
_RAYS: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []


def _ray_directions(az: np.ndarray, el: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Return the unit direction (H, W, 3) of every pixel's ray in the `vehicle` frame (read-only).

    A scanner's angles and mounting do not change from scan to scan, so the last one's are kept.
    """
    for a, e, r, dv in _RAYS:
        if np.array_equal(a, az) and np.array_equal(e, el) and np.array_equal(r, R):
            return dv
    az64 = az.astype(np.float64)
    el64 = el.astype(np.float64)
    ce = np.cos(el64)[:, None]
    dirs = np.stack([ce * np.cos(az64)[None, :], ce * np.sin(az64)[None, :],
                     np.broadcast_to(np.sin(el64)[:, None], (len(el64), len(az64)))], axis=-1)
    dv = dirs @ R.T
    dv.flags.writeable = False
    _RAYS[:] = [(az.copy(), el.copy(), R.copy(), dv)]
    return dv


def scan_points(scan: LaserScan, max_horizontal: float = 20.0) -> np.ndarray:
    """Return the scan's points (N, 4) float32: x, y, z in the `vehicle` frame [m] and σ_z [m], range unwrapped, within `max_horizontal` [m].

    σ_z is the vertical spread that range noise alone gives the point: the scanner's noise model
    σ_r = 0.015 + 0.00012 r² / ρ (ρ the effective reflectance read back from the reflectance image)
    times |sin| of the ray's elevation. Grazing ground returns are weak and noisy; faces of objects are not.
    """
    t = scan.T_vehicle_laser[:3, 3]
    valid = scan.valid.astype(bool)
    dv = _ray_directions(scan.az, scan.el, scan.T_vehicle_laser[:3, :3])
    r = unwrap_over_ground(unwrap_range(scan.range_m, valid, scan.ambiguity).astype(np.float64), valid, dv[..., 2], float(t[2]),
                           scan.ambiguity)
    anchored = anchored_returns(r, valid, dv[..., 2], float(t[2]), scan.ambiguity)
    xyz = dv * r[..., None] + t
    if scan.reflectance is not None:
        atten = 1.0 / (1.0 + np.square(r / 25.0))
        rho = np.clip(scan.reflectance.astype(np.float64) / (255.0 * 1.6 * atten), 0.02, 1.0)
    else:
        rho = np.full(r.shape, 0.3)
    sig = (0.015 + 0.00012 * r * r / rho) * np.abs(dv[..., 2])
    horiz = np.hypot(xyz[..., 0] - t[0], xyz[..., 1] - t[1])
    # pixels at depth discontinuities may be mixed points (the sum of two returns) floating between
    # the surfaces: they are dropped
    keep = anchored & (horiz <= max_horizontal) & ~jump_edges(r.astype(np.float32), valid)
    return np.concatenate([xyz[keep], sig[keep][:, None]], axis=1).astype(np.float32)


def unwrap_over_ground(r: np.ndarray, valid: np.ndarray, dz: np.ndarray, z0: float, ambiguity: float,
                       max_range: float = 40.0, ground_tol: float = 0.6, jump: float = 1.0) -> np.ndarray:
    """Return ranges (H, W) [m] with rays that passed over an object's top and met far ground unwrapped once more.

    Such a return comes back one ambiguity interval short and floats in the air behind the object. A
    pixel is moved out by `ambiguity` when it is not range-continuous with the pixel below it (already
    decided), it floats above the vehicle's ground plane, and one interval farther it lands on that
    plane (within `ground_tol` [m]). `dz` (H, W) is each ray's vertical direction component and `z0` [m]
    the scanner's height, `vehicle` frame.
    """
    r = r.copy()
    h = r.shape[0]
    below = np.full(r.shape[1], np.nan)
    for row in range(h - 1, -1, -1):
        v = valid[row]
        cur = r[row]
        alt = cur + ambiguity
        z_now = z0 + cur * dz[row]
        z_alt = z0 + alt * dz[row]
        broken = ~np.isfinite(below) | (np.abs(cur - below) > jump)
        move = v & broken & (z_now > ground_tol) & (np.abs(z_alt) < ground_tol) & (alt <= max_range)
        cur = np.where(move, alt, cur)
        r[row] = cur
        below = np.where(v, cur, below)
    return r


def anchored_returns(r: np.ndarray, valid: np.ndarray, dz: np.ndarray, z0: float, ambiguity: float,
                     jump: float = 1.0) -> np.ndarray:
    """Return (H, W) bool: the returns whose range [m] is not in doubt by a whole ambiguity interval.

    A ray that meets the vehicle's ground plane within one interval (`dz` (H, W), each ray's vertical
    direction component, below -`z0`/`ambiguity`; `z0` [m] the scanner's height, `vehicle` frame)
    cannot return from farther than that ground, so its unwrapped range stands. A flatter ray can:
    an object one interval beyond the one it shows (a tree 29 m away shows at 8.5 m) folds into the
    near field and floats there at about the scanner's height, where it stopped the vehicle for good
    for something behind the next crossing. Such a return is kept only where it continues, range-
    continuous within `jump` [m], a kept return below it in its column: the upper part of a walker or
    a wall whose foot the lower rays saw, or ground unwrapped by its continuity. What only the flat
    rays see (an overhang at the scanner's height with open ground under it) is the sensor's blind spot.
    """
    sure = valid & (dz < -z0 / ambiguity)
    out = np.zeros(r.shape, dtype=bool)
    below = np.full(r.shape[1], np.nan)
    for row in range(r.shape[0] - 1, -1, -1):
        keep = sure[row] | (valid[row] & (np.abs(r[row] - below) <= jump))
        out[row] = keep
        below = np.where(valid[row], np.where(keep, r[row], np.nan), below)
    return out


def height_map(points: np.ndarray, cfg: ObstacleConfig = ObstacleConfig()) -> HeightMap:
    """Bin `vehicle`-frame points (N, 3 or 4) [m] into a height map (see `HeightMap`).

    The ground of a cell is the lowest mean point height in its neighbourhood; a point is elevated
    when it stands above that ground by more than `min_height` and by more than 3 σ_z (column 4 when
    given). `top` is the highest elevated point per cell, `count` the elevated points per cell.
    """
    nr = int(math.ceil(cfg.x_max / cfg.cell))
    nc = int(math.ceil(2 * cfg.y_half / cfg.cell))
    p = points[(points[:, 2] < cfg.max_height)]
    i = np.floor(p[:, 0] / cfg.cell).astype(np.int64)
    j = np.floor((p[:, 1] + cfg.y_half) / cfg.cell).astype(np.int64)
    ok = (i >= 0) & (i < nr) & (j >= 0) & (j < nc)
    i, j, p = i[ok], j[ok], p[ok]
    z = p[:, 2].astype(np.float64)
    sig = p[:, 3].astype(np.float64) if p.shape[1] > 3 else np.zeros(len(p))
    flat = i * nc + j
    n_all = np.bincount(flat, minlength=nr * nc)
    mean = np.bincount(flat, weights=z, minlength=nr * nc) / np.maximum(n_all, 1)
    mean = np.where(n_all > 0, mean, np.inf).reshape(nr, nc)
    k = 2 * cfg.ground_radius + 1
    ground = minimum_filter(mean, size=k, mode="constant", cval=np.inf)
    g = ground.ravel()[flat]
    h = z - g
    up = (h > cfg.min_height) & (h > 3.0 * sig)
    top = np.full(nr * nc, -np.inf)
    np.maximum.at(top, flat[up], z[up])
    count = np.bincount(flat[up], minlength=nr * nc).astype(np.int32).reshape(nr, nc)
    top = top.reshape(nr, nc)
    top = np.where(count > 0, top, np.where(n_all.reshape(nr, nc) > 0, ground, np.nan))
    ground = np.where(n_all.reshape(nr, nc) > 0, ground, np.nan)
    return HeightMap(top=top.astype(np.float32), ground=ground.astype(np.float32), count=count, cell=cfg.cell, y_half=cfg.y_half)


def detect_obstacles(scan: LaserScan, cfg: ObstacleConfig = ObstacleConfig()) -> list[Obstacle]:
    """Find obstacles in one range image: polygons with heights in the `vehicle` frame, nearest first."""
    return obstacles_from_points(scan_points(scan, cfg.max_horizontal), cfg)


def obstacles_from_points(pts: np.ndarray, cfg: ObstacleConfig = ObstacleConfig()) -> list[Obstacle]:
    """Find obstacles among `vehicle`-frame points (N, 3 or 4: x, y, z [m], σ_z [m]) of any range sensor, nearest first."""
    hm = height_map(pts, cfg)
    tall = hm.count > 0
    # a cell counts when a neighbour is tall too or it holds several points (lone mixed points drop out)
    support = maximum_filter(tall.astype(np.uint8), size=3) & tall
    lab, n = cc_label(support, structure=np.ones((3, 3), int))
    out: list[Obstacle] = []
    if n == 0:
        return out
    idx = np.nonzero(lab)
    ids = lab[idx]
    for k in range(1, n + 1):
        sel = ids == k
        ii, jj = idx[0][sel], idx[1][sel]
        npts = int(hm.count[ii, jj].sum())
        if npts < cfg.min_points:
            continue
        x0 = ii * cfg.cell
        y0 = jj * cfg.cell - cfg.y_half
        corners = np.concatenate([np.stack([x0 + dx, y0 + dy], -1) for dx in (0.0, cfg.cell) for dy in (0.0, cfg.cell)])
        hull = cv2.convexHull(corners.astype(np.float32)).reshape(-1, 2).astype(np.float64)
        h = float(np.max(hm.height[ii, jj]))
        cx, cy = (ii + 0.5) * cfg.cell, (jj + 0.5) * cfg.cell - cfg.y_half
        out.append(Obstacle(polygon=tuple((float(a), float(b)) for a, b in hull), height=h,
                            centroid=(float(cx.mean()), float(cy.mean())),
                            distance=float(np.min(np.hypot(x0 + 0.5 * cfg.cell, y0 + 0.5 * cfg.cell))), points=npts))
    out.sort(key=lambda o: o.distance)
    return out


def path_clear_distance(scan: LaserScan, path: np.ndarray, half_width: float, cfg: ObstacleConfig = ObstacleConfig(),
                        min_points: int = 3) -> float:
    """Return the distance along `path` (K, 2) [m] (`vehicle` frame) to the first obstacle point in its corridor [m].

    The fast mode: only points within `half_width` [m] of the path are kept; a point is an obstacle
    point when it stands `min_height` above the lowest corridor point near it. Returns `inf` when the
    corridor is clear (as far as the scan sees).
    """
    pts = scan_points(scan, cfg.max_horizontal)
    path = np.asarray(path, np.float64)
    if len(path) < 2 or len(pts) == 0:
        return math.inf
    # only points in the path's box grown by the half width can lie in the corridor: the point-to-segment
    # distances below (points × segments) are worked out for those alone, in the scan's order, so the
    # result is the same to the bit (the margin covers the float32 → float64 of the exact test)
    lo = path.min(axis=0) - (half_width + 1e-6)
    hi = path.max(axis=0) + (half_width + 1e-6)
    near = (pts[:, 0] >= lo[0]) & (pts[:, 0] <= hi[0]) & (pts[:, 1] >= lo[1]) & (pts[:, 1] <= hi[1])
    pts = pts[near]
    if len(pts) == 0:
        return math.inf
    a, b = path[:-1], path[1:]
    e = b - a
    L = np.linalg.norm(e, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(L)])
    # per coordinate on (points, segments) arrays: the same sums and roots as a norm over a last axis of two
    rx = pts[:, 0:1].astype(np.float64) - a[None, :, 0]
    ry = pts[:, 1:2].astype(np.float64) - a[None, :, 1]
    ex, ey = e[None, :, 0], e[None, :, 1]
    t = np.clip((rx * ex + ry * ey) / np.maximum(L * L, 1e-12)[None], 0.0, 1.0)
    dx = rx - t * ex
    dy = ry - t * ey
    d = np.sqrt(dx * dx + dy * dy)
    seg = np.argmin(d, axis=1)
    dmin = d[np.arange(len(pts)), seg]
    inside = dmin <= half_width
    if not inside.any():
        return math.inf
    s = cum[seg] + t[np.arange(len(pts)), seg] * L[seg]
    s, z, sig = s[inside], pts[inside, 2], pts[inside, 3]
    # ground along the corridor: the lowest point within ±1 m of arc length (or the vehicle's ground)
    order = np.argsort(s)
    s, z, sig = s[order], z[order], sig[order]
    bins = np.floor(s / 0.5).astype(np.int64)
    nb = int(bins.max()) + 1
    low = np.full(nb, np.inf)
    cnt = np.bincount(bins, minlength=nb)
    low = np.bincount(bins, weights=z.astype(np.float64), minlength=nb) / np.maximum(cnt, 1)
    low = np.where(cnt > 0, low, np.inf)
    low = minimum_filter(low, size=5, mode="nearest")
    low = np.where(np.isfinite(low), low, 0.0)
    hz = z - low[bins]
    hot = (hz > cfg.min_height) & (hz > 3.0 * sig) & (z < cfg.max_height)
    if hot.sum() < min_points:
        return math.inf
    hs = s[hot]
    return float(hs[min_points - 1])


def path_in_vehicle(points: np.ndarray, pose: tuple[float, float, float], lookahead: float) -> np.ndarray:
    """Return a path ahead of the vehicle, (K, 2) [m] in the `vehicle` frame from its origin, about `lookahead` [m] long.

    `points` (N, 2) [m] and `pose` (x, y [m], yaw [rad]) are in `local`; the part behind the vehicle is
    dropped and a path that ends short carries on straight (no points: straight ahead).
    """
    p = np.asarray(points, np.float64).reshape(-1, 2)
    if len(p) == 0:
        return np.array([[0.0, 0.0], [lookahead, 0.0]])
    c, s = math.cos(pose[2]), math.sin(pose[2])
    v = (p - (pose[0], pose[1])) @ np.array([[c, -s], [s, c]])
    i = int(np.argmin(np.linalg.norm(v, axis=1)))
    ahead = v[i:]
    ahead = ahead[ahead[:, 0] > 0.0]
    out = np.vstack([[0.0, 0.0], ahead]) if len(ahead) else np.array([[0.0, 0.0], [lookahead, 0.0]])
    seg = np.linalg.norm(np.diff(out, axis=0), axis=1)
    keep = np.concatenate([[True], np.cumsum(seg) <= lookahead + seg.max(initial=0.0)])
    out = out[keep]
    length = float(np.linalg.norm(np.diff(out, axis=0), axis=1).sum())
    if length < lookahead:  # the plan ends short of the look-ahead (it reaches only the newest driving unit): carry on straight
        d = out[-1] - out[-2]
        d = d / max(float(np.linalg.norm(d)), 1e-9)
        out = np.vstack([out, out[-1] + (lookahead - length) * d])
    return out
