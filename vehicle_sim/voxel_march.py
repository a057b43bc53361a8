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
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["march_ground"]


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def march_ground(ox: float, oy: float, oz: float, ca: np.ndarray, sa: np.ndarray, tan_el: np.ndarray,
                 S: np.ndarray, grid_flat: np.ndarray, grid_w: int, grid_h: int, origin_x: float, origin_y: float,
                 inv_res: float, any_tilted: bool, g_z0: np.ndarray, g_tilted: np.ndarray, g_a0: np.ndarray,
                 g_a1: np.ndarray, g_b: np.ndarray, g_steps: np.ndarray, g_rise: np.ndarray, g_normal: np.ndarray,
                 g_riser_normal: np.ndarray, s_buf: np.ndarray, mat: np.ndarray, normal: np.ndarray,
                 tex: np.ndarray, riser_out: np.ndarray) -> None:
    """March the ground for rays from (ox, oy, oz) [m]: columns (ca, sa) (W,) float32, rows `tan_el` (H,) float32.

    Writes, per ray (H, W): `s_buf` horizontal distance [m] (inf: the ground is not reached within
    `S`), `mat` ground material (-1: none), `normal` (H, W, 3) unit normal, `tex` (H, W, 2) texture
    cell and `riser_out` (the ray met the ground at a vertical step). A ray that misses keeps the
    normal the step test of the last two samples gives it, as the array version did. Every output
    is overwritten.
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
            z = g_z0[m]
            if any_tilted and g_tilted[m]:
                t = x * g_a0[m] + y * g_a1[m] - g_b[m]
                t = min(max(t, zero), one)
                n = g_steps[m]
                if n > zero:
                    g = (min(np.float32(np.floor(t * n)), n - one) + one) / max(n, one)
                else:
                    g = t
                z += np.float32(g_rise[m] * g)
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
            else:
                normal[i, j, 0] = g_normal[gm, 0]
                normal[i, j, 1] = g_normal[gm, 1]
                normal[i, j, 2] = g_normal[gm, 2]
            sf = sg if hit else zero
            tex[i, j, 0] = np.int32((f_ox + sf * c) * f_inv_res)
            tex[i, j, 1] = np.int32((f_oy + sf * s) * f_inv_res)
            riser_out[i, j] = riser and hit
