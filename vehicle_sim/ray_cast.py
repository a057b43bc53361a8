"""Rays in any direction cast into the scene, compiled: the ground (covers and terrain) and the standing solids.

`Scene.cast` renders a *level* grid of rays (each column a vertical half-plane). A sensor on a vehicle
rolled and pitched by rough ground has no such grid: each of its rays has an azimuth and elevation of
its own. Here every ray is marched on its own. Each ray is parametrised, as in the level renderer, by
its horizontal distance s [m] from the origin: the point (ox + s·ca, oy + s·sa, oz + s·tan). The
ground is sampled at the level renderer's distances `S` until it rises to the ray, and the crossing is
interpolated between that sample and the one before (a riser takes the step face), so a level ray
meets the ground where the level renderer's does. Rays come in image order and are taken column by
column from the bottom row up: a ray above the one below it (nearly the same azimuth) cannot meet
the ground before the lower ray did, so its march starts a little short of that crossing (if the
ground is already above the ray there, it starts again from the origin). Solids (vertical cylinders, ellipsoids with a
vertical axis, vertical prisms) are intersected exactly; each ray tests only the solids whose
azimuth interval, seen from the origin, holds it (`bin_solids`). Frames: `world` (x east, y north,
z up) [m].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vehicle_sim.voxel_march import cover_height, ground_normal, terrain_height

__all__ = ["bin_solids", "cast_rays"]


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _wrap(a: float) -> float:
    return (a + np.pi) % (2.0 * np.pi) - np.pi


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def bin_solids(cx: np.ndarray, cy: np.ndarray, radius: np.ndarray, ox: float, oy: float, az_mid: float, az_lo: float,
               inv_width: float, n_bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Return (start (n_bins + 1,), index) listing, per azimuth bin, the round-bounded solids whose angular span meets it.

    Solid k has centre (cx[k], cy[k]) and radius `radius[k]` [m]; bin b covers azimuths
    az_mid + az_lo + [b, b + 1) / inv_width [rad]; a solid within 0.5 m of the origin is in every bin.
    """
    n = cx.shape[0]
    b0 = np.empty(n, np.int64)
    b1 = np.empty(n, np.int64)
    counts = np.zeros(n_bins + 1, np.int64)
    for k in range(n):
        dx, dy = cx[k] - ox, cy[k] - oy
        d = math.hypot(dx, dy)
        if d <= radius[k] + 0.5:
            lo, hi = 0, n_bins - 1
        else:
            half = math.asin(min(radius[k] / d, 1.0)) + 1e-3
            rel = _wrap(math.atan2(dy, dx) - az_mid)
            lo = int(math.floor((rel - half - az_lo) * inv_width))
            hi = int(math.floor((rel + half - az_lo) * inv_width))
            lo, hi = max(lo, 0), min(hi, n_bins - 1)
        b0[k], b1[k] = lo, hi
        for b in range(lo, hi + 1):
            counts[b + 1] += 1
    start = np.cumsum(counts)
    fill = start[:-1].copy()
    index = np.empty(start[-1], np.int64)
    for k in range(n):
        for b in range(b0[k], b1[k] + 1):
            index[fill[b]] = k
            fill[b] += 1
    return start, index


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _round_hit(ox: float, oy: float, oz: float, c: float, s: float, t: float, cx: float, cy: float, r: float,
               zb: float, zt: float, best: float) -> tuple[float, float, float, float]:
    """Return (s, nx, ny, nz) where the ray meets a vertical cylinder's side or top nearer than `best`, else (inf, …)."""
    qx, qy = cx - ox, cy - oy
    p = qx * c + qy * s
    perp2 = qx * qx + qy * qy - p * p
    if not (perp2 < r * r and p > 0):
        return np.inf, 0.0, 0.0, 0.0
    half = math.sqrt(max(r * r - perp2, 0.0))
    s_in = max(p - half, 0.05)
    s_out = p + half
    z_in = oz + s_in * t
    if zb <= z_in <= zt:
        if s_in < best:
            hx, hy = ox + s_in * c - cx, oy + s_in * s - cy
            return s_in, hx / r, hy / r, 0.0
    elif z_in > zt and t < 0:
        s_top = (zt - oz) / t
        if s_top <= s_out and s_top < best:
            return s_top, 0.0, 0.0, 1.0
    return np.inf, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _ellipsoid_hit(ox: float, oy: float, oz: float, c: float, s: float, t: float, cx: float, cy: float, zc: float,
                   R: float, b: float, best: float) -> tuple[float, float, float, float]:
    """Return (s, nx, ny, nz) where the ray meets an ellipsoid (vertical half-axis b, horizontal R) nearer than `best`."""
    # horizontal distance s; point (ox + s c - cx, oy + s s - cy, oz + s t - zc); scaled sphere of radius R
    px, py, pz = ox - cx, oy - cy, (oz - zc) * (R / b)
    tz = t * (R / b)
    A = c * c + s * s + tz * tz
    B = 2.0 * (px * c + py * s + pz * tz)
    C = px * px + py * py + pz * pz - R * R
    disc = B * B - 4.0 * A * C
    if not disc >= 0:
        return np.inf, 0.0, 0.0, 0.0
    sq = math.sqrt(disc)
    s1 = (-B - sq) / (2.0 * A)
    s2 = (-B + sq) / (2.0 * A)
    s_new = s1 if s1 > 0 else s2
    if not (s_new > 0 and s_new < best):
        return np.inf, 0.0, 0.0, 0.0
    hx, hy, hz = ox + s_new * c - cx, oy + s_new * s - cy, oz + s_new * t - zc
    nx, ny, nz = hx / (R * R), hy / (R * R), hz / (b * b)
    nn = max(math.sqrt(nx * nx + ny * ny + nz * nz), 1e-9)
    return s_new, nx / nn, ny / nn, nz / nn


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _prism_hit(ox: float, oy: float, oz: float, c: float, s: float, t: float, k: int, verts: np.ndarray, start: np.ndarray,
               edges: np.ndarray, edges_unit: np.ndarray, zb: float, zt: float, best: float) -> tuple[float, float, float, float]:
    """Return (s, nx, ny, nz) where the ray meets prism k's wall (the nearest footprint edge crossed) or roof, nearer than `best`."""
    v0, v1 = start[k], start[k + 1]
    near, far, eb = np.inf, -np.inf, -1
    for e in range(v0, v1):
        wx, wy = verts[e, 0] - ox, verts[e, 1] - oy
        ex, ey = edges[e, 0], edges[e, 1]
        den = c * ey - s * ex
        if abs(den) <= 1e-12:
            continue
        se = (wx * ey - wy * ex) / den
        tau = (wx * s - wy * c) / den
        if 0 <= tau <= 1 and se > 0:
            if se < near:
                near, eb = se, e
            far = max(far, se)
    if eb < 0:
        return np.inf, 0.0, 0.0, 0.0
    s_in = max(near, 0.05)
    z_in = oz + s_in * t
    if zb <= z_in <= zt:
        if s_in < best:
            nx, ny = edges_unit[eb, 1], -edges_unit[eb, 0]
            if nx * c + ny * s > 0:  # the wall faces the sensor
                nx, ny = -nx, -ny
            return s_in, nx, ny, 0.0
    elif z_in > zt and t < 0:
        s_top = (zt - oz) / t
        if s_top <= far and s_top < best:
            return s_top, 0.0, 0.0, 1.0
    return np.inf, 0.0, 0.0, 0.0


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _march(f_ox: np.float32, f_oy: np.float32, f_oz: np.float32, c32: np.float32, s32: np.float32, t32: np.float32,
           S: np.ndarray, k_start: int, grid_flat: np.ndarray, grid_w: int, grid_h: int, f_org_x: np.float32,
           f_org_y: np.float32, f_inv_res: np.float32, any_tilted: bool, g_z0: np.ndarray, g_tilted: np.ndarray,
           g_a0: np.ndarray, g_a1: np.ndarray, g_b: np.ndarray, g_steps: np.ndarray, g_rise: np.ndarray,
           has_terrain: bool, t_z: np.ndarray, t_ox: float, t_oy: float, t_inv_res: float
           ) -> tuple[bool, int, np.float32, np.float32, int, int]:
    """March one ray from sample `k_start`: return (hit, k, h0, h1, g0, g1), the first sample k at or above the ray and
    the ground heights [m] and materials of samples k - 1 and k."""
    nS = S.shape[0]
    h0, h1 = np.float32(0.0), np.float32(0.0)
    g0, g1 = 0, 0
    for k in range(k_start, nS):
        x = f_ox + c32 * S[k]
        y = f_oy + s32 * S[k]
        ix = min(max(np.int32((x - f_org_x) * f_inv_res), 0), grid_w - 1)
        iy = min(max(np.int32((y - f_org_y) * f_inv_res), 0), grid_h - 1)
        m = np.int32(grid_flat[iy * grid_w + ix])
        z = cover_height(x, y, m, any_tilted, g_z0, g_tilted, g_a0, g_a1, g_b, g_steps, g_rise)
        if has_terrain:
            z += terrain_height(x, y, t_z, t_ox, t_oy, t_inv_res)
        h0, g0 = h1, g1
        h1, g1 = z, m
        if (z - f_oz) / S[k] >= t32:
            return True, k, h0, h1, g0, g1
    return False, nS, h0, h1, g0, g1


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def cast_rays(ox: float, oy: float, oz: float, ca: np.ndarray, sa: np.ndarray, tan: np.ndarray, S: np.ndarray,
              grid_flat: np.ndarray, grid_w: int, grid_h: int, origin_x: float, origin_y: float, inv_res: float,
              any_tilted: bool, g_z0: np.ndarray, g_tilted: np.ndarray, g_a0: np.ndarray, g_a1: np.ndarray,
              g_b: np.ndarray, g_steps: np.ndarray, g_rise: np.ndarray, g_normal: np.ndarray, g_riser_normal: np.ndarray,
              has_terrain: bool, t_z: np.ndarray, t_ox: float, t_oy: float, t_inv_res: float,
              az_mid: float, az_lo: float, inv_bin: float, n_bins: int,
              cylinders: np.ndarray, cyl_start: np.ndarray, cyl_index: np.ndarray,
              ellipsoids: np.ndarray, ell_start: np.ndarray, ell_index: np.ndarray,
              p_verts: np.ndarray, p_start: np.ndarray, p_edges: np.ndarray, p_unit: np.ndarray, p_zb: np.ndarray,
              p_zt: np.ndarray, p_mat: np.ndarray, pr_start: np.ndarray, pr_index: np.ndarray,
              rows: int, s_out: np.ndarray, mat_out: np.ndarray, normal_out: np.ndarray, riser_out: np.ndarray) -> None:
    """Cast rays (N,) from (ox, oy, oz) [m]: horizontal direction (ca, sa), slope `tan` [m/m] (float64), in image order:
    N = `rows` × (N // rows), row 0 the top.

    Ground as `voxel_march.march_ground` (materials of `grid_flat`, terrain `t_z` when `has_terrain`),
    then cylinders (n, 6) [cx, cy, r, z_bottom, z_top, material], ellipsoids (n, 6) [cx, cy, z_centre, R, b,
    material] and the packed prisms (`p_*`), each listed per azimuth bin (`*_start`, `*_index`, from
    `bin_solids` with `az_mid`, `az_lo`, `inv_bin`, `n_bins`). Writes per ray: `s_out` horizontal distance
    [m] (inf: nothing within `S`), `mat_out` material (-1: none), `normal_out` (N, 3) unit normal,
    `riser_out` (the ground was met at a vertical step).
    """
    N = ca.shape[0]
    nS = S.shape[0]
    cols = N // rows
    f_ox, f_oy, f_oz = np.float32(ox), np.float32(oy), np.float32(oz)
    f_org_x, f_org_y, f_inv_res = np.float32(origin_x), np.float32(origin_y), np.float32(inv_res)
    ground_s = np.full(cols, np.nan)  # per column: where the ray below met the ground [m]
    for q_ in range(N):
        j, i = q_ // rows, rows - 1 - q_ % rows  # column by column, from the bottom row up
        q = i * cols + j
        c, s, t = ca[q], sa[q], tan[q]
        c32, s32, t32 = np.float32(c), np.float32(s), np.float32(t)
        # ---- ground: the first sample at or above the ray, from a little short of the lower ray's crossing
        k_start = 0
        if i < rows - 1 and tan[q + cols] <= t and ground_s[j] == ground_s[j]:
            k_start = max(np.searchsorted(S, np.float32(0.9 * ground_s[j] - 0.3)) - 1, 0)
        hit, k, h0, h1, g0, g1 = _march(f_ox, f_oy, f_oz, c32, s32, t32, S, k_start, grid_flat, grid_w, grid_h, f_org_x,
                                        f_org_y, f_inv_res, any_tilted, g_z0, g_tilted, g_a0, g_a1, g_b, g_steps, g_rise,
                                        has_terrain, t_z, t_ox, t_oy, t_inv_res)
        if hit and k == k_start and k_start > 0:  # the ground rose above the ray before the lower one's crossing
            hit, k, h0, h1, g0, g1 = _march(f_ox, f_oy, f_oz, c32, s32, t32, S, 0, grid_flat, grid_w, grid_h, f_org_x,
                                            f_org_y, f_inv_res, any_tilted, g_z0, g_tilted, g_a0, g_a1, g_b, g_steps,
                                            g_rise, has_terrain, t_z, t_ox, t_oy, t_inv_res)
        ground_s[j] = np.float64(S[k]) if hit else np.float64(S[nS - 1])
        best = np.inf
        m_best = -1
        nx, ny, nz = 0.0, 0.0, 1.0
        riser = False
        if hit:
            if k == 0:  # already under the ground at the first sample: take it
                sg = np.float64(S[0])
            else:
                s0, s1 = S[k - 1], S[k]
                d0 = f_oz + s0 * t32 - h0
                d1 = f_oz + s1 * t32 - h1
                riser = (h1 - h0) > np.float32(0.03) and not (g1 == g0 and g_steps[g1] == np.float32(0.0))
                if riser:
                    sg = np.float64(s1)
                else:
                    frac = min(max(d0 / max(d0 - d1, np.float32(1e-6)), np.float32(0.0)), np.float32(1.0))
                    sg = np.float64(s0 + (s1 - s0) * frac)
            best, m_best = sg, g1
            if riser:
                if g1 == g0:
                    nx, ny, nz = g_riser_normal[g1, 0], g_riser_normal[g1, 1], g_riser_normal[g1, 2]
                else:
                    nx, ny, nz = -c, -s, 0.0
            elif has_terrain:
                nx, ny, nz = ground_normal(ox + sg * c, oy + sg * s, g_normal[g1, 0], g_normal[g1, 1], g_normal[g1, 2],
                                           t_z, t_ox, t_oy, t_inv_res)
            else:
                nx, ny, nz = g_normal[g1, 0], g_normal[g1, 1], g_normal[g1, 2]
        # ---- solids in this ray's azimuth bin
        b = int(math.floor((_wrap(math.atan2(s, c) - az_mid) - az_lo) * inv_bin))
        if 0 <= b < n_bins:
            for u in range(cyl_start[b], cyl_start[b + 1]):
                kk = cyl_index[u]
                sh, hx, hy, hz = _round_hit(ox, oy, oz, c, s, t, cylinders[kk, 0], cylinders[kk, 1], cylinders[kk, 2],
                                            cylinders[kk, 3], cylinders[kk, 4], best)
                if sh < best:
                    best, m_best, nx, ny, nz, riser = sh, np.int32(cylinders[kk, 5]), hx, hy, hz, False
            for u in range(ell_start[b], ell_start[b + 1]):
                kk = ell_index[u]
                sh, hx, hy, hz = _ellipsoid_hit(ox, oy, oz, c, s, t, ellipsoids[kk, 0], ellipsoids[kk, 1], ellipsoids[kk, 2],
                                                ellipsoids[kk, 3], ellipsoids[kk, 4], best)
                if sh < best:
                    best, m_best, nx, ny, nz, riser = sh, np.int32(ellipsoids[kk, 5]), hx, hy, hz, False
            for u in range(pr_start[b], pr_start[b + 1]):
                kk = pr_index[u]
                sh, hx, hy, hz = _prism_hit(ox, oy, oz, c, s, t, kk, p_verts, p_start, p_edges, p_unit, p_zb[kk], p_zt[kk], best)
                if sh < best:
                    best, m_best, nx, ny, nz, riser = sh, p_mat[kk], hx, hy, hz, False
        s_out[q] = best
        mat_out[q] = m_best
        normal_out[q, 0] = nx
        normal_out[q, 1] = ny
        normal_out[q, 2] = nz
        riser_out[q] = riser
