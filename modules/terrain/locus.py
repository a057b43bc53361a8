"""The locus method (Navlab 1990 §2.3.5, Figure 2.13): a dense elevation map from one range image, in image space.

The elevation at (x, y) is where the vertical line through (x, y) meets the surface the sensor saw.
That surface is the image itself: between adjacent pixels it is interpolated, so the crossing is
found between two adjacent pixels and its height interpolated from theirs (to first order in the
pixel pitch, the interpolation in range between (r1, c1) and (r2, c2) of the paper is the facet
through the two pixels' points, which is what is interpolated here). Every 2 × 2 block of pixels
gives two triangular facets; each facet is laid over the map and every cell centre under it takes
the facet's height there, the highest facet winning (the first crossing walking down the vertical
line, i.e. the nearest surface seen from above). This visits only the cells under the image, each
once or twice, so a map as fine as 10 cm costs milliseconds.

Uncertainty: the range sigma of each pixel (`RangeImage.sigma`) moves its point along its ray; on
the facet that moves the crossing with the vertical line by sigma·|n·d| / |n_z| (n the facet's
normal, d the ray), and the cell combines its facet's three pixels with their interpolation weights.

Unknown cells (NaN, sigma inf): cells under no facet (never seen, out of view, no return) and cells
whose highest crossing is a facet spanning a **range discontinuity**: a range shadow, the ground
behind an obstacle the sensor could not see. Adjacent pixels are across a discontinuity when the
range steps between them far more than the steps two to four pixels away along the same row or
column do: more than `ratio` times their median, by more than `noise_k` times the two pixels'
range sigmas together (noise alone makes grazing ground step unevenly), and by at least `min_step`.
A facet the rays meet at less than `min_incidence` (seen edge-on) is taken for a shadow too: it
spans the gap between an occluder and the ground behind it even where the noise hides the step.
Comparing with the steps two pixels away lets a mixed point (a return between the two surfaces,
Navlab §2.3.1) split a gap without hiding it; grazing ground, whose steps grow smoothly with range,
is not a discontinuity.

Frames: the map in `world` (the grid's frame); rays from the image in `laser`, placed by the pose
estimate world ← vehicle and the mount vehicle ← laser.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.grid_spec import GridSpec
from modules.terrain.range_image import RangeImage

__all__ = ["LocusParams", "locus_map", "image_points", "range_jumps"]


@dataclass(frozen=True)
class LocusParams:
    """Discontinuity test (range steps against their neighbours and the noise) and the map's reach [m] (horizontal)."""

    ratio: float = 2.5
    noise_k: float = 4.0
    min_step: float = 0.3  # [m]
    min_incidence: float = 0.035  # a facet the rays meet at less than this (sine; 2°) is seen edge-on: a shadow
    max_range: float = 20.0
    shadow_margin: float = 0.02  # a shadow facet this far [m] above the seen surface hides it


def image_points(image: RangeImage, world_from_vehicle: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the image's points (H, W, 3), ray directions (H, W, 3) in `world` [m] and the sensor origin (3,), float64.

    Points of pixels without a return are NaN.
    """
    T = image.world_from_laser(world_from_vehicle)
    d = image.directions() @ T[:3, :3].T
    p = T[:3, 3] + d * image.range.astype(np.float64)[..., None]
    return p, d, T[:3, 3].copy()


@njit(cache=True, nogil=True, boundscheck=False)
def _median(buf: np.ndarray, n: int) -> float:
    for a in range(1, n):  # insertion sort of the first n values
        v = buf[a]
        b = a - 1
        while b >= 0 and buf[b] > v:
            buf[b + 1] = buf[b]
            b -= 1
        buf[b + 1] = v
    return buf[n // 2] if n % 2 == 1 else 0.5 * (buf[n // 2 - 1] + buf[n // 2])


@njit(cache=True, nogil=True, boundscheck=False)
def _jumps_along(step: np.ndarray, noise: np.ndarray, ratio: float, noise_k: float, min_step: float) -> np.ndarray:
    """Return the discontinuities (n,) bool among the range steps (n,) [m] along one row or column (NaN = no step), each
    step's noise (n,) [m] being the sigma of the difference of its two ranges."""
    n = step.shape[0]
    out = np.zeros(n, np.bool_)
    buf = np.empty(6)
    for k in range(n):
        s = step[k]
        if not s > min_step:
            continue
        m = 0
        for off in (-4, -3, -2, 2, 3, 4):
            q = k + off
            if 0 <= q < n and step[q] == step[q]:
                buf[m] = step[q]
                m += 1
        ref = _median(buf, m) if m >= 2 else 0.0
        out[k] = s > ratio * ref and s - ref > noise_k * noise[k]
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def _range_jumps(rng: np.ndarray, sig: np.ndarray, ratio: float, noise_k: float, min_step: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    H, W = rng.shape
    dv = np.full((W, H - 1), np.nan)  # per column, the steps down it
    nv = np.zeros((W, H - 1))
    dh = np.full((H, W - 1), np.nan)
    nh = np.zeros((H, W - 1))
    for i in range(H):
        for j in range(W):
            r0 = rng[i, j]
            if not r0 == r0:
                continue
            if i + 1 < H and rng[i + 1, j] == rng[i + 1, j]:
                dv[j, i] = abs(rng[i + 1, j] - r0)
                nv[j, i] = np.sqrt(sig[i, j] ** 2 + sig[i + 1, j] ** 2)
            if j + 1 < W and rng[i, j + 1] == rng[i, j + 1]:
                dh[i, j] = abs(rng[i, j + 1] - r0)
                nh[i, j] = np.sqrt(sig[i, j] ** 2 + sig[i, j + 1] ** 2)
    jv = np.zeros((H - 1, W), np.bool_)
    jh = np.zeros((H, W - 1), np.bool_)
    for j in range(W):
        col = _jumps_along(dv[j], nv[j], ratio, noise_k, min_step)
        for i in range(H - 1):
            jv[i, j] = col[i]
    for i in range(H):
        jh[i] = _jumps_along(dh[i], nh[i], ratio, noise_k, min_step)
    return jv, jh


def range_jumps(image: RangeImage, params: LocusParams = LocusParams()) -> tuple[np.ndarray, np.ndarray]:
    """Return the range discontinuities between vertically (H - 1, W) and horizontally (H, W - 1) adjacent pixels, bool."""
    return _range_jumps(image.range.astype(np.float64), image.sigma.astype(np.float64), params.ratio, params.noise_k,
                        params.min_step)


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _facet(zv: np.ndarray, sv: np.ndarray, zs: np.ndarray, shadow: bool, ax: float, ay: float, az: float, sa: float,
           bx: float, by: float, bz: float, sb: float, cx: float, cy: float, cz: float, sc: float, ox: float, oy: float,
           inv_res: float) -> None:
    """Lay one facet (three points [m], world, with their z sigmas [m]) over the grid: the highest crossing per cell wins."""
    ny, nx = zv.shape
    ua, va = (ax - ox) * inv_res - 0.5, (ay - oy) * inv_res - 0.5  # grid coordinates: cell centres at integers
    ub, vb = (bx - ox) * inv_res - 0.5, (by - oy) * inv_res - 0.5
    uc, vc = (cx - ox) * inv_res - 0.5, (cy - oy) * inv_res - 0.5
    det = (ub - ua) * (vc - va) - (uc - ua) * (vb - va)
    if abs(det) < 1e-9:
        return
    i0 = max(int(np.ceil(min(va, vb, vc))), 0)
    i1 = min(int(np.floor(max(va, vb, vc))), ny - 1)
    for i in range(i0, i1 + 1):
        v = float(i)
        lo, hi = np.inf, -np.inf
        if (va <= v <= vb or vb <= v <= va) and va != vb:
            u = ua + (v - va) * (ub - ua) / (vb - va)
            lo, hi = min(lo, u), max(hi, u)
        if (vb <= v <= vc or vc <= v <= vb) and vb != vc:
            u = ub + (v - vb) * (uc - ub) / (vc - vb)
            lo, hi = min(lo, u), max(hi, u)
        if (vc <= v <= va or va <= v <= vc) and vc != va:
            u = uc + (v - vc) * (ua - uc) / (va - vc)
            lo, hi = min(lo, u), max(hi, u)
        j0 = max(int(np.ceil(lo - 1e-9)), 0)
        j1 = min(int(np.floor(hi + 1e-9)), nx - 1)
        for j in range(j0, j1 + 1):
            du, dv = j - ua, v - va
            w1 = ((vc - va) * du - (uc - ua) * dv) / det
            w2 = (-(vb - va) * du + (ub - ua) * dv) / det
            w1 = min(max(w1, 0.0), 1.0)
            w2 = min(max(w2, 0.0), 1.0 - w1)
            w0 = 1.0 - w1 - w2
            z = w0 * az + w1 * bz + w2 * cz
            if shadow:
                if z > zs[i, j]:
                    zs[i, j] = z
            elif z > zv[i, j] or zv[i, j] != zv[i, j]:  # NaN: nothing laid there yet
                zv[i, j] = z
                sv[i, j] = np.sqrt((w0 * sa) ** 2 + (w1 * sb) ** 2 + (w2 * sc) ** 2)


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _z_sigma(p: np.ndarray, d: np.ndarray, sr: np.ndarray, ai: int, aj: int, bi: int, bj: int, ci: int, cj: int
             ) -> tuple[float, float, float, float]:
    """Return the z sigmas [m] of a facet's three pixels (each range sigma moved along its ray onto the vertical line)
    and the sine of the angle at which the first pixel's ray meets the facet."""
    ux, uy, uz = p[bi, bj, 0] - p[ai, aj, 0], p[bi, bj, 1] - p[ai, aj, 1], p[bi, bj, 2] - p[ai, aj, 2]
    vx, vy, vz = p[ci, cj, 0] - p[ai, aj, 0], p[ci, cj, 1] - p[ai, aj, 1], p[ci, cj, 2] - p[ai, aj, 2]
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    nn = np.sqrt(nx * nx + ny * ny + nz * nz)
    if nn < 1e-12:
        return np.inf, np.inf, np.inf, 0.0
    inv = 1.0 / (nn * max(abs(nz) / nn, 0.2))
    incidence = abs(nx * d[ai, aj, 0] + ny * d[ai, aj, 1] + nz * d[ai, aj, 2]) / nn
    sa = sr[ai, aj] * abs(nx * d[ai, aj, 0] + ny * d[ai, aj, 1] + nz * d[ai, aj, 2]) * inv
    sb = sr[bi, bj] * abs(nx * d[bi, bj, 0] + ny * d[bi, bj, 1] + nz * d[bi, bj, 2]) * inv
    sc = sr[ci, cj] * abs(nx * d[ci, cj, 0] + ny * d[ci, cj, 1] + nz * d[ci, cj, 2]) * inv
    return sa, sb, sc, incidence


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _lay(p: np.ndarray, d: np.ndarray, sr: np.ndarray, near: np.ndarray, zv: np.ndarray, sv: np.ndarray, zs: np.ndarray,
         shadow: bool, ai: int, aj: int, bi: int, bj: int, ci: int, cj: int, ox: float, oy: float, inv_res: float,
         min_incidence: float) -> None:
    """Lay the facet of pixels a, b, c over the grid when all three are within reach; a facet seen edge-on is a shadow."""
    if not (near[ai, aj] and near[bi, bj] and near[ci, cj]):
        return
    s0, s1, s2, incidence = _z_sigma(p, d, sr, ai, aj, bi, bj, ci, cj)
    _facet(zv, sv, zs, shadow or incidence < min_incidence, p[ai, aj, 0], p[ai, aj, 1], p[ai, aj, 2], s0, p[bi, bj, 0], p[bi, bj, 1], p[bi, bj, 2], s1,
           p[ci, cj, 0], p[ci, cj, 1], p[ci, cj, 2], s2, ox, oy, inv_res)


@njit(cache=True, nogil=True, boundscheck=False)
def _locus(p: np.ndarray, d: np.ndarray, rng: np.ndarray, sr: np.ndarray, jv: np.ndarray, jh: np.ndarray, origin: np.ndarray,
           max_range: float, ox: float, oy: float, res: float, ny: int, nx: int, shadow_margin: float, noise_k: float,
           min_step: float, min_incidence: float) -> tuple[np.ndarray, np.ndarray]:
    H, W = sr.shape
    zv = np.full((ny, nx), np.nan, np.float32)
    sv = np.full((ny, nx), np.inf, np.float32)
    zs = np.full((ny, nx), -np.inf, np.float32)
    inv_res = 1.0 / res
    r2 = (1.1 * max_range) ** 2  # facets reaching a little beyond cover the cells out to max_range
    near = np.zeros((H, W), np.bool_)
    for i in range(H):
        for j in range(W):
            if p[i, j, 0] == p[i, j, 0]:
                near[i, j] = (p[i, j, 0] - origin[0]) ** 2 + (p[i, j, 1] - origin[1]) ** 2 <= r2
    for i in range(H - 1):
        for j in range(W - 1):
            if not (near[i, j] and near[i + 1, j + 1]):
                continue
            # the diagonal (i, j)–(i + 1, j + 1) spans a discontinuity when a side of the block does and it steps too
            diagonal = (jv[i, j] or jv[i, j + 1] or jh[i, j] or jh[i + 1, j]) and \
                abs(rng[i + 1, j + 1] - rng[i, j]) > max(min_step, noise_k * np.sqrt(sr[i, j] ** 2 + sr[i + 1, j + 1] ** 2))
            _lay(p, d, sr, near, zv, sv, zs, jv[i, j] or jh[i + 1, j] or diagonal, i, j, i + 1, j, i + 1, j + 1, ox, oy, inv_res,
                 min_incidence)
            _lay(p, d, sr, near, zv, sv, zs, jv[i, j + 1] or jh[i, j] or diagonal, i, j, i + 1, j + 1, i, j + 1, ox, oy, inv_res,
                 min_incidence)
    m2 = max_range * max_range
    for i in range(ny):
        cy = oy + (i + 0.5) * res - origin[1]
        for j in range(nx):
            cx = ox + (j + 0.5) * res - origin[0]
            # the highest crossing is in a shadow (never true for NaN), or the cell is out of reach
            if zs[i, j] > zv[i, j] + shadow_margin or cx * cx + cy * cy > m2:
                zv[i, j] = np.nan
                sv[i, j] = np.inf
    return zv, sv


def locus_map(image: RangeImage, world_from_vehicle: np.ndarray, spec: GridSpec, params: LocusParams = LocusParams()
              ) -> ElevationGrid:
    """Return the locus elevation map of one range image on the grid `spec`, the vehicle at world ← vehicle (4, 4).

    Cells the image does not see, and cells in its range shadows, are unknown (NaN, sigma inf).
    """
    p, d, origin = image_points(image, world_from_vehicle)
    jv, jh = range_jumps(image, params)
    sr = image.sigma.astype(np.float64)
    z, sigma = _locus(p, d, image.range.astype(np.float64), sr, jv, jh, origin, params.max_range, spec.origin_x,
                      spec.origin_y, spec.resolution, spec.ny, spec.nx, params.shadow_margin, params.noise_k, params.min_step,
                      params.min_incidence)
    return ElevationGrid(spec.origin_x, spec.origin_y, spec.resolution, z, sigma, spec.frame)
