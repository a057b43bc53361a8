"""The standing solids of `Scene.cast` intersected analytically per ray, compiled: cylinders, ellipsoids, prisms.

Posts and tree trunks are vertical cylinders, tree crowns ellipsoids with a vertical axis, buildings,
hedges, benches and actors vertical prisms (a footprint polygon between two heights). For each solid
the columns whose vertical half-plane meets its footprint are found, then the rows whose ray
tangent can reach its height span, and every ray there is intersected exactly; a hit nearer than
what the depth buffer holds replaces it (distance, material, normal, texture coordinates). Solids
are taken in the order given, so of two equally near surfaces the first one drawn stays.

Written as one loop per ray so it runs compiled and without the GIL (the laser and the camera
render on two threads). The arithmetic is the array version's, operation for operation and in
the same precision (float64 but for the float32 ray tables), so the depth buffer comes out the
same to the last bit. Frames: `world` (x east, y north, z up) [m]; the ray grid is level: columns
(`ca`, `sa`) are world azimuth cosines and sines, rows `tan` the elevation tangents, descending.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["cast_cylinders", "cast_ellipsoids", "cast_prisms"]

_TEX_RES = 0.06  # texture sampling pitch on solids [m] (vehicle_sim.scene's)
_INV_TEX = 1.0 / _TEX_RES


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _row_span(neg_tan: np.ndarray, lo: float, hi: float) -> tuple[int, int]:
    """Return the rows [r0, r1) whose ray tangents lie in [lo, hi] (tangents descend with the row; compared in float64)."""
    H = neg_tan.shape[0]
    r0 = 0
    while r0 < H and np.float64(neg_tan[r0]) < -hi:
        r0 += 1
    r1 = r0
    while r1 < H and np.float64(neg_tan[r1]) <= -lo:
        r1 += 1
    return r0, r1


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _commit(s: np.ndarray, mat: np.ndarray, normal: np.ndarray, tex: np.ndarray, i: int, j: int, s_new: float,
            m: int, nx: float, ny: float, nz: float, tu: float, tv: float) -> None:
    s[i, j] = s_new
    mat[i, j] = m
    normal[i, j, 0] = nx
    normal[i, j, 1] = ny
    normal[i, j, 2] = nz
    tex[i, j, 0] = np.int32(tu)
    tex[i, j, 1] = np.int32(tv)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _circle_window(ox: float, oy: float, ca: np.ndarray, sa: np.ndarray, cx: float, cy: float, r: float,
                   p: np.ndarray, half: np.ndarray) -> tuple[int, int]:
    """Fill `p` (along-ray distance to the centre [m]) and `half` (half chord [m]; NaN where the column's ray
    misses the circle) for every column; return the window [c0, c1) from the first to the last column that meets it."""
    W = ca.shape[0]
    qx = cx - ox
    qy = cy - oy
    c0, c1 = -1, -1
    for j in range(W):
        pj = qx * np.float64(ca[j]) + qy * np.float64(sa[j])
        perp2 = (qx * qx + qy * qy) - pj * pj
        p[j] = pj
        if perp2 < r * r and pj > 0:
            half[j] = math.sqrt(max(r * r - perp2, 0.0))
            if c0 < 0:
                c0 = j
            c1 = j + 1
        else:
            half[j] = np.nan
    return c0, c1


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _any_farther(s: np.ndarray, r0: int, r1: int, c0: int, c1: int, near: float) -> bool:
    for i in range(r0, r1):
        for j in range(c0, c1):
            if np.float64(s[i, j]) > near:
                return True
    return False


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _round_solid_rows(p: np.ndarray, half: np.ndarray, c0: int, c1: int, dz_lo_in: float, dz_lo_out: float,
                      dz_hi_in: float, dz_hi_out: float, neg_tan: np.ndarray, s: np.ndarray) -> tuple[int, int]:
    """Return the rows [r0, r1) whose rays can meet a round solid in columns [c0, c1), from its lowest and highest
    points over the sensor (dz_* [m]) at the near and far side of each column's chord; (0, 0) when no ray can, or
    when the depth buffer holds nothing farther than the solid's nearest point there."""
    lo, hi, near = np.inf, -np.inf, np.inf
    for j in range(c0, c1):
        if half[j] == half[j]:
            s_in = max(p[j] - half[j], 0.05)
            s_out = p[j] + half[j]
            lo = min(lo, min(dz_lo_in / s_in, dz_lo_out / s_out))
            hi = max(hi, max(dz_hi_in / s_in, dz_hi_out / s_out))
            near = min(near, s_in)
    r0, r1 = _row_span(neg_tan, lo, hi)
    if r1 <= r0 or not _any_farther(s, r0, r1, c0, c1, near):
        return 0, 0
    return r0, r1


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def _wall_column(s: np.ndarray, mat: np.ndarray, normal: np.ndarray, tex: np.ndarray, j: int, r0: int, r1: int,
                 tan: np.ndarray, oz: float, s_in: float, s_out: float, zb: float, zt: float, top_in_float32: bool,
                 m: int, nx: float, ny: float, tu: float) -> None:
    """Intersect the rays of column j, rows [r0, r1), with a vertical solid the column's ray enters at `s_in` and
    leaves at `s_out` [m], between heights `zb` and `zt` [m]: its wall (normal (nx, ny, 0)) or, from above, its top
    (normal up). A prism's top distance is taken in float32, as the array version did (its heights were weak
    Python scalars there)."""
    rise = zt - oz
    rise32 = np.float32(rise)
    for i in range(r0, r1):
        t = np.float64(tan[i])
        z_in = oz + s_in * t
        side = z_in >= zb and z_in <= zt
        if side:
            s_new = s_in
        elif z_in > zt and t < 0:
            s_new = np.float64(rise32 / tan[i]) if top_in_float32 else rise / t
            if not s_new <= s_out:
                continue
        else:
            continue
        if not s_new < s[i, j]:
            continue
        tv = (oz + s_new * t) * _INV_TEX
        if side:
            _commit(s, mat, normal, tex, i, j, s_new, m, nx, ny, 0.0, tu, tv)
        else:
            _commit(s, mat, normal, tex, i, j, s_new, m, 0.0, 0.0, 1.0, tu, tv)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def cast_cylinders(ox: float, oy: float, oz: float, ca: np.ndarray, sa: np.ndarray, tan: np.ndarray,
                   neg_tan: np.ndarray, cylinders: np.ndarray, s: np.ndarray, mat: np.ndarray,
                   normal: np.ndarray, tex: np.ndarray) -> None:
    """Intersect vertical cylinders (n, 6) [cx, cy, r, z_bottom, z_top, material] [m] into the depth buffer.

    A ray meets the side between the two heights or, from above, the top cap.
    """
    W = ca.shape[0]
    p = np.empty(W)
    half = np.empty(W)
    for k in range(cylinders.shape[0]):
        cx, cy, r, zb, zt = cylinders[k, 0], cylinders[k, 1], cylinders[k, 2], cylinders[k, 3], cylinders[k, 4]
        m = np.int32(cylinders[k, 5])
        c0, c1 = _circle_window(ox, oy, ca, sa, cx, cy, r, p, half)
        if c0 < 0:
            continue
        r0, r1 = _round_solid_rows(p, half, c0, c1, zb - oz, zt - oz, zt - oz, zt - oz, neg_tan, s)
        if r1 <= r0:
            continue
        for j in range(c0, c1):
            if half[j] != half[j]:
                continue
            s_in = max(p[j] - half[j], 0.05)
            s_out = p[j] + half[j]
            cj, sj = np.float64(ca[j]), np.float64(sa[j])
            hx = ox + s_in * cj - cx
            hy = oy + s_in * sj - cy
            _wall_column(s, mat, normal, tex, j, r0, r1, tan, oz, s_in, s_out, zb, zt, False, m, hx / r, hy / r,
                         math.atan2(hy, hx) * (r / _TEX_RES))


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def cast_ellipsoids(ox: float, oy: float, oz: float, ca: np.ndarray, sa: np.ndarray, tan: np.ndarray,
                    neg_tan: np.ndarray, ellipsoids: np.ndarray, s: np.ndarray, mat: np.ndarray,
                    normal: np.ndarray, tex: np.ndarray) -> None:
    """Intersect ellipsoids with a vertical axis (n, 6) [cx, cy, z_centre, R, b, material] [m] into the depth buffer.

    In a column's half-plane the ellipsoid is an ellipse of half-width `half` (the chord) and
    half-height b·half/R; the ray meets it at the nearer positive root.
    """
    W = ca.shape[0]
    p = np.empty(W)
    half = np.empty(W)
    for k in range(ellipsoids.shape[0]):
        cx, cy, zc, R, b = ellipsoids[k, 0], ellipsoids[k, 1], ellipsoids[k, 2], ellipsoids[k, 3], ellipsoids[k, 4]
        m = np.int32(ellipsoids[k, 5])
        c0, c1 = _circle_window(ox, oy, ca, sa, cx, cy, R, p, half)
        if c0 < 0:
            continue
        r0, r1 = _round_solid_rows(p, half, c0, c1, zc - b - oz, zc - b - oz, zc + b - oz, zc + b - oz, neg_tan, s)
        if r1 <= r0:
            continue
        dz0 = oz - zc
        for j in range(c0, c1):
            if half[j] != half[j]:
                continue
            a = max(half[j], 1e-6)
            bb = b * a / R
            pp = p[j]
            ia2, ib2 = 1.0 / (a * a), 1.0 / (bb * bb)
            cj, sj = np.float64(ca[j]), np.float64(sa[j])
            for i in range(r0, r1):
                t32 = tan[i]
                t = np.float64(t32)
                A = ia2 + np.float64(t32 * t32) * ib2
                B = -2.0 * pp * ia2 + 2.0 * dz0 * t * ib2
                C = pp * pp * ia2 + dz0 * dz0 * ib2 - 1.0
                disc = B * B - 4 * A * C
                if not disc >= 0:
                    continue
                sq = math.sqrt(disc)
                s1 = (-B - sq) / (2 * A)
                s2 = (-B + sq) / (2 * A)
                s_new = s1 if s1 > 0 else s2
                if not (s_new > 0 and s_new < s[i, j]):
                    continue
                hx = ox + s_new * cj - cx
                hy = oy + s_new * sj - cy
                hz = oz + s_new * t - zc
                nx = hx * (1.0 / (R * R))
                ny = hy * (1.0 / (R * R))
                nz = hz * (1.0 / (b * b))
                nn = max(math.sqrt(nx * nx + ny * ny + nz * nz), 1e-9)
                _commit(s, mat, normal, tex, i, j, s_new, m, nx / nn, ny / nn, nz / nn,
                        (hx - hy) * _INV_TEX, (hz + 0.7 * hx) * _INV_TEX)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy")
def cast_prisms(ox: float, oy: float, oz: float, ca: np.ndarray, sa: np.ndarray, tan: np.ndarray,
                neg_tan: np.ndarray, neg_az: np.ndarray, az_mid: float, which: np.ndarray, verts: np.ndarray,
                start: np.ndarray, edges: np.ndarray, edges_unit: np.ndarray, z_bottom: np.ndarray,
                z_top: np.ndarray, material: np.ndarray, s: np.ndarray, mat: np.ndarray, normal: np.ndarray,
                tex: np.ndarray) -> None:
    """Intersect the vertical prisms `which` (indices) into the depth buffer: footprint k is `verts[start[k]:start[k+1]]`
    (M, 2) [m] with its edge vectors and unit edges (vertex to next) and heights z_bottom..z_top [m].

    A ray meets the wall of the nearest footprint edge it crosses or, from above, the roof.
    `neg_az` holds minus the columns' world azimuths when they descend (else it is empty), to
    limit each prism to the columns of its angular span.
    """
    W = ca.shape[0]
    s_in_col = np.empty(W)
    s_out_col = np.empty(W)
    j_in_col = np.empty(W, np.int64)
    for q in range(which.shape[0]):
        k = which[q]
        v0, v1 = start[k], start[k + 1]
        M = v1 - v0
        zb, zt = z_bottom[k], z_top[k]
        m = material[k]
        b0, b1 = 0, W
        dmin = np.inf
        for e in range(M):
            dmin = min(dmin, math.hypot(verts[v0 + e, 0] - ox, verts[v0 + e, 1] - oy))
        if dmin > 1.0 and neg_az.shape[0] > 0:
            rmin, rmax = np.inf, -np.inf
            for e in range(M):
                rel = (math.atan2(verts[v0 + e, 1] - oy, verts[v0 + e, 0] - ox) - az_mid + np.pi) % (2 * np.pi) - np.pi
                rmin = min(rmin, rel)
                rmax = max(rmax, rel)
            if rmax - rmin < np.pi:
                lo_az, hi_az = rmin + az_mid, rmax + az_mid
                i0 = 0
                while i0 < W and neg_az[i0] < -hi_az:
                    i0 += 1
                i1 = i0
                while i1 < W and neg_az[i1] <= -lo_az:
                    i1 += 1
                b0 = max(0, i0 - 1)
                b1 = min(W, i1 + 1)
                if b1 <= b0:
                    continue
        c0, c1 = -1, -1
        lo, hi, near = np.inf, -np.inf, np.inf
        for j in range(b0, b1):
            ux, uy = np.float64(ca[j]), np.float64(sa[j])
            best, far, jb = np.inf, -np.inf, 0
            for e in range(M):
                wx, wy = verts[v0 + e, 0] - ox, verts[v0 + e, 1] - oy
                ex, ey = edges[v0 + e, 0], edges[v0 + e, 1]
                den = ux * ey - uy * ex
                se = (wx * ey - wy * ex) / den
                tau = (wx * uy - wy * ux) / den
                if abs(den) > 1e-12 and tau >= 0 and tau <= 1 and se > 0:
                    if se < best:
                        best, jb = se, e
                    if se > far:
                        far = se
            s_in_col[j] = best
            s_out_col[j] = far
            j_in_col[j] = jb
            if best < np.inf:
                if c0 < 0:
                    c0 = j
                c1 = j + 1
                s_in_c = max(best, 0.05)
                lo = min(lo, min((zb - oz) / s_in_c, (zt - oz) / far))
                hi = max(hi, max((zt - oz) / s_in_c, (zt - oz) / far))
                near = min(near, s_in_c)
        if c0 < 0:
            continue
        r0, r1 = _row_span(neg_tan, lo, hi)
        if r1 <= r0 or not _any_farther(s, r0, r1, c0, c1, near):
            continue
        for j in range(c0, c1):
            s_in = s_in_col[j]
            if not s_in < np.inf:
                continue
            s_out = s_out_col[j]
            e = v0 + j_in_col[j]
            enx, eny = edges_unit[e, 0], edges_unit[e, 1]
            cj, sj = np.float64(ca[j]), np.float64(sa[j])
            nx, ny = eny, -enx
            if nx * cj + ny * sj > 0:  # the wall faces the sensor
                nx, ny = -nx, -ny
            hx = ox + s_in * cj
            hy = oy + s_in * sj
            along = (hx - verts[e, 0]) * enx + (hy - verts[e, 1]) * eny
            _wall_column(s, mat, normal, tex, j, r0, r1, tan, oz, s_in, s_out, zb, zt, True, m, nx, ny, along * _INV_TEX)
