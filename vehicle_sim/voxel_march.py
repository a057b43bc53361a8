"""The ground of `Scene.cast` found by a voxel-space march, compiled: one column's height profile, every row's crossing.

Each column of a level azimuth/elevation ray grid is a vertical half-plane. The ground is sampled
along it at the horizontal distances `S` [m] (nearest raster cell; analytic height per material), the
elevation-angle tangent of each sample seen from the origin is kept as a running maximum, and the
ray of each row meets the ground at the first sample whose running maximum reaches the ray's
tangent; the crossing is interpolated between that sample and the one before (at a riser, the step
face is taken). This is the "voxel-space" renderer of `vehicle_sim.scene`'s docstring, written as
one loop per ray so it runs compiled and without the GIL: the laser's scan and the camera's
exposure, rendered on two threads, march on two cores at once.

Arithmetic is float32 throughout, in the order the array version used, so hits agree with it to
the last bit except where a ray's tangent equals a sample's to within 1e-11 (the array version
compared tangents offset by 256 per column in float64). Frames: `world` (x east, y north, z up) [m].

In a world with terrain (`has_terrain`) the terrain raster's bilinear height (`terrain_height`) is
added to every sample's and the hit's ground normal follows the terrain's slope (`terrain_gradient`);
flat worlds take none of this and march exactly as before.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["march_ground", "cover_height", "terrain_height", "terrain_gradient", "ground_normal"]


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def cover_height(x: np.float32, y: np.float32, m: int, any_tilted: bool, g_z0: np.ndarray, g_tilted: np.ndarray,
                 g_a0: np.ndarray, g_a1: np.ndarray, g_b: np.ndarray, g_steps: np.ndarray, g_rise: np.ndarray) -> np.float32:
    """Return the height [m] (float32) of ground material `m` at world point (x, y) [m]: its z0, plus its slope or step rise."""
    z = g_z0[m]
    if any_tilted and g_tilted[m]:
        t = x * g_a0[m] + y * g_a1[m] - g_b[m]
        t = min(max(t, np.float32(0.0)), np.float32(1.0))
        n = g_steps[m]
        if n > np.float32(0.0):
            g = (min(np.float32(np.floor(t * n)), n - np.float32(1.0)) + np.float32(1.0)) / max(n, np.float32(1.0))
        else:
            g = t
        z += np.float32(g_rise[m] * g)
    return z


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _terrain_cell(x: float, y: float, t_z: np.ndarray, t_ox: float, t_oy: float, t_inv_res: float) -> tuple[int, int, float, float]:
    """Return the raster sample (i, j) below-left of world point (x, y) [m] and the fractions (fu, fv) into its cell."""
    ny, nx = t_z.shape
    u = min(max((x - t_ox) * t_inv_res, 0.0), nx - 1.0)
    v = min(max((y - t_oy) * t_inv_res, 0.0), ny - 1.0)
    j = min(int(u), nx - 2)
    i = min(int(v), ny - 2)
    return i, j, u - j, v - i


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def terrain_height(x: float, y: float, t_z: np.ndarray, t_ox: float, t_oy: float, t_inv_res: float) -> np.float32:
    """Return the terrain raster's bilinear height [m] (float32) at world point (x, y) [m] (edge samples hold outside)."""
    i, j, fu, fv = _terrain_cell(x, y, t_z, t_ox, t_oy, t_inv_res)
    z0 = t_z[i, j] * (1.0 - fu) + t_z[i, j + 1] * fu
    z1 = t_z[i + 1, j] * (1.0 - fu) + t_z[i + 1, j + 1] * fu
    return np.float32(z0 * (1.0 - fv) + z1 * fv)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def terrain_gradient(x: float, y: float, t_z: np.ndarray, t_ox: float, t_oy: float, t_inv_res: float) -> tuple[float, float]:
    """Return the terrain's slope (dz/dx, dz/dy) [m/m] at world point (x, y) [m], of the bilinear cell holding it."""
    i, j, fu, fv = _terrain_cell(x, y, t_z, t_ox, t_oy, t_inv_res)
    gx = ((t_z[i, j + 1] - t_z[i, j]) * (1.0 - fv) + (t_z[i + 1, j + 1] - t_z[i + 1, j]) * fv) * t_inv_res
    gy = ((t_z[i + 1, j] - t_z[i, j]) * (1.0 - fu) + (t_z[i + 1, j + 1] - t_z[i, j + 1]) * fu) * t_inv_res
    return gx, gy


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def ground_normal(x: float, y: float, nx: float, ny: float, nz: float, t_z: np.ndarray, t_ox: float, t_oy: float,
                  t_inv_res: float) -> tuple[float, float, float]:
    """Return the unit normal of a ground material with normal (nx, ny, nz) laid on the terrain at (x, y) [m]."""
    gx, gy = terrain_gradient(x, y, t_z, t_ox, t_oy, t_inv_res)
    inv = 1.0 / max(nz, 1e-6)
    ax = -(gx - nx * inv)
    ay = -(gy - ny * inv)
    nn = np.sqrt(ax * ax + ay * ay + 1.0)
    return ax / nn, ay / nn, 1.0 / nn


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def march_ground(ox: float, oy: float, oz: float, ca: np.ndarray, sa: np.ndarray, tan_el: np.ndarray,
                 S: np.ndarray, grid_flat: np.ndarray, grid_w: int, grid_h: int, origin_x: float, origin_y: float,
                 inv_res: float, any_tilted: bool, g_z0: np.ndarray, g_tilted: np.ndarray, g_a0: np.ndarray,
                 g_a1: np.ndarray, g_b: np.ndarray, g_steps: np.ndarray, g_rise: np.ndarray, g_normal: np.ndarray,
                 g_riser_normal: np.ndarray, s_buf: np.ndarray, mat: np.ndarray, normal: np.ndarray,
                 tex: np.ndarray, riser_out: np.ndarray, has_terrain: bool, t_z: np.ndarray,
                 t_ox: float, t_oy: float, t_inv_res: float) -> None:
    """March the ground for rays from (ox, oy, oz) [m]: columns (ca, sa) (W,) float32, rows `tan_el` (H,) float32.

    Writes, per ray (H, W): `s_buf` horizontal distance [m] (inf: the ground is not reached within
    `S`), `mat` ground material (-1: none), `normal` (H, W, 3) unit normal, `tex` (H, W, 2) texture
    cell and `riser_out` (the ray met the ground at a vertical step). A ray that misses keeps the
    normal the step test of the last two samples gives it, as the array version did. Every output
    is overwritten. With `has_terrain`, the terrain raster `t_z` (ny, nx) float32 [m] (sample (0, 0) at
    (t_ox, t_oy) [m], 1 / spacing `t_inv_res` [1/m]) lies under every material.
    """
    H = tan_el.shape[0]
    W = ca.shape[0]
    nS = S.shape[0]
    f_ox = np.float32(ox)
    f_oy = np.float32(oy)
    f_oz = np.float32(oz)
    f_org_x = np.float32(origin_x)
    f_org_y = np.float32(origin_y)
    f_inv_res = np.float32(inv_res)
    lo = np.float32(-120.0)
    hi = np.float32(120.0)
    step_min = np.float32(0.03)
    den_min = np.float32(1e-6)
    zero = np.float32(0.0)
    one = np.float32(1.0)
    inf = np.float32(np.inf)
    Hg = np.empty(nS, np.float32)
    G = np.empty(nS, np.int32)
    A = np.empty(nS, np.float32)
    for j in range(W):
        c = ca[j]
        s = sa[j]
        run = lo
        for k in range(nS):
            x = f_ox + c * S[k]
            y = f_oy + s * S[k]
            ix = np.int32((x - f_org_x) * f_inv_res)
            iy = np.int32((y - f_org_y) * f_inv_res)
            ix = min(max(ix, 0), grid_w - 1)
            iy = min(max(iy, 0), grid_h - 1)
            m = np.int32(grid_flat[iy * grid_w + ix])
            z = cover_height(x, y, m, any_tilted, g_z0, g_tilted, g_a0, g_a1, g_b, g_steps, g_rise)
            if has_terrain:
                z += terrain_height(x, y, t_z, t_ox, t_oy, t_inv_res)
            Hg[k] = z
            G[k] = m
            a = (z - f_oz) / S[k]
            a = min(max(a, lo), hi)
            if a > run or k == 0:
                run = a
            A[k] = run
        for i in range(H):
            t = tan_el[i]
            # first sample whose running maximum reaches t (binary search: A does not decrease)
            a_lo, a_hi = 0, nS
            while a_lo < a_hi:
                mid = (a_lo + a_hi) >> 1
                if A[mid] < t:
                    a_lo = mid + 1
                else:
                    a_hi = mid
            k = a_lo
            hit = k < nS
            k0 = min(max(k, 1), nS - 1) - 1
            h0 = Hg[k0]
            h1 = Hg[k0 + 1]
            s0 = S[k0]
            s1 = S[k0 + 1]
            g0 = G[k0]
            g1 = G[k0 + 1]
            d0 = f_oz + s0 * t - h0
            d1 = f_oz + s1 * t - h1
            riser = (h1 - h0) > step_min and not (g1 == g0 and g_steps[g1] == zero)
            frac = d0 / max(d0 - d1, den_min)
            frac = min(max(frac, zero), one)
            if riser:
                sg = s1
            else:
                sg = s0 + (s1 - s0) * frac
            if k == 0:
                sg = S[0]
            riser = riser and k > 0
            gm = g1 if hit else 0
            s_buf[i, j] = sg if hit else inf
            mat[i, j] = g1 if hit else -1
            if riser:
                if g1 == g0:
                    normal[i, j, 0] = g_riser_normal[gm, 0]
                    normal[i, j, 1] = g_riser_normal[gm, 1]
                    normal[i, j, 2] = g_riser_normal[gm, 2]
                else:
                    normal[i, j, 0] = -c
                    normal[i, j, 1] = -s
                    normal[i, j, 2] = zero
            elif has_terrain and hit:
                nx, ny, nz = ground_normal(f_ox + sg * c, f_oy + sg * s, g_normal[gm, 0], g_normal[gm, 1], g_normal[gm, 2],
                                           t_z, t_ox, t_oy, t_inv_res)
                normal[i, j, 0] = nx
                normal[i, j, 1] = ny
                normal[i, j, 2] = nz
            else:
                normal[i, j, 0] = g_normal[gm, 0]
                normal[i, j, 1] = g_normal[gm, 1]
                normal[i, j, 2] = g_normal[gm, 2]
            sf = sg if hit else zero
            tex[i, j, 0] = np.int32((f_ox + sf * c) * f_inv_res)
            tex[i, j, 1] = np.int32((f_oy + sf * s) * f_inv_res)
            riser_out[i, j] = riser and hit
