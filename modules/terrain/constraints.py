"""The planner's constraints (Navlab 1990 §2.4, Figure 2.15): each at one configuration, and bounded over a whole voxel.

A configuration is the vehicle's reference point (x, y) [m] in the grid's frame and its heading θ
[rad] (CCW from +x). On a grid of cell size r:

- **sensing**: the cells whose centres lie under the body (its box in `vehicle`; cells off the grid
  count) hold at most `max_unknown_share` × body area / r² unknown cells, and every wheel patch holds
  a known cell;
- **tip-over**: a wheel rests on the highest known cell whose centre lies within its patch (radius
  `wheel_patch`, at least r/√2) of its contact point; the least-squares plane through the wheels, z̄ + u·tan(pitch) + v·tan(roll) in
  `vehicle` (the layout is symmetric, so tan(pitch) = Σuᵢzᵢ / Σuᵢ², tan(roll) = Σvᵢzᵢ / Σvᵢ²), has
  |roll| ≤ `max_roll` and |pitch| ≤ `max_pitch`;
- **high-centring**: no known cell under the belly (between the foremost and rearmost wheels) rises
  more than `clearance` above that plane;
- **collision**: no known cell under the overhangs (ahead of and behind the wheels) rises more than
  `overhang_clearance` above that plane, and no wheel patch holds a cell whose discontinuity (the
  pyramid's, level 0) exceeds `max_step`.

`evaluate_configuration` checks one configuration on the grid itself. `voxel_bounds` (compiled)
bounds every constraint over a voxel — a square of configurations' positions times an interval of
headings — from pyramid nodes only, and says whether all, none, or some of its configurations
satisfy it (the paper's three cases). It writes the terrain as one plane P (fitted to the nodes under
the body) plus residuals: a wheel's height is P at the wheel plus eᵢ, with eᵢ bounded by the residuals
of the nodes its patch can reach, so pitch and roll are bounded by P's slope along the heading
interval plus Σuᵢeᵢ / Σuᵢ², and a cell's rise above the wheels' plane by its own residual minus
Σαᵢeᵢ (αᵢ the plane's affine weights, extremal at a box's corners). Bounds are conservative: a voxel
called admissible holds no violating configuration; one called inadmissible holds no admissible one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numba import njit

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import TerrainError
from modules.terrain.pyramid import (F_ABOVE, F_BELOW, F_CELLS, F_COUNT, F_DISC, F_ZMAX, F_PGX, F_PGY, F_PZ, F_SX, F_SXX,
                                     F_SXY, F_SXZ, F_SY, F_SYY, F_SYZ, F_ZSUM, TerrainPyramid)
from modules.terrain.vehicle_model import TerrainVehicle

__all__ = ["Constraint", "constraints_in", "ConfigurationVerdict", "evaluate_configuration", "VehicleArrays",
           "voxel_bounds", "configuration_bits", "wheel_patch_on", "allowed_unknown", "ADMISSIBLE", "INADMISSIBLE", "MIXED"]


class Constraint(str, Enum):
    """The kinds of constraint on a configuration the voxels are classified by."""

    SENSING = "sensing"
    TIP_OVER = "tip-over"
    HIGH_CENTRING = "high-centring"
    COLLISION = "collision"


#: A constraint's bit in the masks the compiled code returns.
_BITS = {Constraint.SENSING: 1, Constraint.TIP_OVER: 2, Constraint.HIGH_CENTRING: 4, Constraint.COLLISION: 8}
B_SENSING, B_TIP, B_HIGH, B_COLLIDE = 1, 2, 4, 8
#: A voxel's class: all its configurations satisfy every constraint / one constraint fails for all / neither.
ADMISSIBLE, INADMISSIBLE, MIXED = 1, 2, 3


def constraints_in(mask: int) -> tuple[Constraint, ...]:
    """Return the constraints whose bits are set in `mask`."""
    return tuple(c for c, b in _BITS.items() if mask & b)


@dataclass(frozen=True)
class ConfigurationVerdict:
    """One configuration checked on the grid: the constraints it violates and the figures they come from.

    `roll`, `pitch` [rad] of the wheels' plane (NaN when a wheel has no known cell); `belly_rise`,
    `overhang_rise` [m] the highest known cell above that plane under the belly and the overhangs;
    `wheel_step` [m] the largest discontinuity under a wheel; `unknown` the unknown cells under the body.
    """

    violated: tuple[Constraint, ...]
    roll: float
    pitch: float
    belly_rise: float
    overhang_rise: float
    wheel_step: float
    unknown: int

    @property
    def admissible(self) -> bool:
        """Return whether the configuration satisfies every constraint."""
        return not self.violated


def allowed_unknown(vehicle: TerrainVehicle, resolution: float, max_unknown_share: float) -> int:
    """Return how many unknown cells of size `resolution` [m] may lie under the body."""
    area = (vehicle.body_rear + vehicle.body_front) * 2.0 * vehicle.body_half_width
    return int(math.floor(max_unknown_share * area / resolution ** 2 + 1e-9))


def wheel_patch_on(vehicle: TerrainVehicle, resolution: float) -> float:
    """Return the wheel patch radius [m] on cells of `resolution` [m]: at least r/√2, so every patch holds a cell centre."""
    return max(vehicle.wheel_patch, resolution * math.sqrt(0.5) * 1.0001)


def evaluate_configuration(grid: ElevationGrid, pyramid: TerrainPyramid, vehicle: TerrainVehicle, x: float, y: float,
                           theta: float, max_unknown_share: float = 0.0) -> ConfigurationVerdict:
    """Check configuration (x [m], y [m], θ [rad]) in the grid's frame against every constraint, cell by cell."""
    if pyramid.shape != grid.shape:
        raise TerrainError(f"the pyramid ({pyramid.shape}) is not the grid's ({grid.shape})")
    r = grid.resolution
    ny, nx = grid.shape
    c, s = math.cos(theta), math.sin(theta)
    reach = math.hypot(max(vehicle.body_rear, vehicle.body_front), vehicle.body_half_width) + r
    i0, i1 = int(math.floor((y - reach - grid.origin_y) / r)), int(math.floor((y + reach - grid.origin_y) / r))
    j0, j1 = int(math.floor((x - reach - grid.origin_x) / r)), int(math.floor((x + reach - grid.origin_x) / r))
    ii, jj = np.mgrid[i0:i1 + 1, j0:j1 + 1]
    cx, cy = grid.origin_x + (jj + 0.5) * r - x, grid.origin_y + (ii + 0.5) * r - y
    u, v = c * cx + s * cy, -s * cx + c * cy
    inside = (ii >= 0) & (ii < ny) & (jj >= 0) & (jj < nx)
    z = np.full(ii.shape, np.nan)
    disc = np.full(ii.shape, np.nan)
    z[inside] = grid.z[ii[inside], jj[inside]]
    disc[inside] = pyramid.level(0).disc[ii[inside], jj[inside]]
    known = ~np.isnan(z)
    body = (u >= -vehicle.body_rear) & (u <= vehicle.body_front) & (np.abs(v) <= vehicle.body_half_width)
    unknown = int(np.count_nonzero(body & ~known))
    violated: set[Constraint] = set()
    if unknown > allowed_unknown(vehicle, r, max_unknown_share):
        violated.add(Constraint.SENSING)
    wheels = np.array(vehicle.wheels)
    zw = np.full(len(wheels), np.nan)
    step = 0.0
    for k, (wu, wv) in enumerate(wheels):
        patch = known & (np.hypot(u - wu, v - wv) <= wheel_patch_on(vehicle, r))
        if patch.any():
            zw[k] = z[patch].max()
            step = max(step, float(np.nanmax(disc[patch])))
    roll = pitch = belly = overhang = float("nan")
    if np.isnan(zw).any():
        violated.add(Constraint.SENSING)
    else:
        tp = float(wheels[:, 0] @ zw / (wheels[:, 0] @ wheels[:, 0]))
        tr = float(wheels[:, 1] @ zw / (wheels[:, 1] @ wheels[:, 1]))
        pitch, roll = math.atan(tp), math.atan(tr)
        if abs(roll) > vehicle.max_roll or abs(pitch) > vehicle.max_pitch:
            violated.add(Constraint.TIP_OVER)
        rise = z - (zw.mean() + u * tp + v * tr)
        ua0, ua1 = vehicle.axle_span
        in_belly = body & known & (u >= ua0) & (u <= ua1)
        in_over = body & known & ~((u >= ua0) & (u <= ua1))
        belly = float(rise[in_belly].max()) if in_belly.any() else -math.inf
        overhang = float(rise[in_over].max()) if in_over.any() else -math.inf
        if belly > vehicle.clearance:
            violated.add(Constraint.HIGH_CENTRING)
        if overhang > vehicle.overhang_clearance:
            violated.add(Constraint.COLLISION)
    if step > vehicle.max_step:
        violated.add(Constraint.COLLISION)
    order = list(Constraint)
    return ConfigurationVerdict(tuple(sorted(violated, key=order.index)), roll, pitch, belly, overhang, step, unknown)


# Rows of VehicleArrays.scalars.
S_PATCH, S_TAN_ROLL, S_TAN_PITCH, S_STEP, S_ALLOWED, S_SUU, S_SVV, S_COVER = range(8)


@dataclass(frozen=True)
class VehicleArrays:
    """A vehicle as the compiled bounds read it, for a grid of `resolution` [m].

    `wheels` (n, 2) float64 contact points (u, v) [m]; `moments` (7,) float64 their sums
    (Σu², Σv², Σuv, Σu³, Σu²v, Σuv², Σv³); `boxes` (m, 6) float64 body parts
    (u0, u1, v0, v1 [m], clearance [m], kind: 0 belly, 1 overhang) — the belly and each overhang cut
    in halves (and the belly also along its length) so a rock taints only its part's bound; `body`
    (4,) float64 (u0, u1, v0, v1); `scalars` (8,) float64 indexed by S_*.
    """

    wheels: np.ndarray
    moments: np.ndarray
    boxes: np.ndarray
    body: np.ndarray
    scalars: np.ndarray

    @classmethod
    def of(cls, vehicle: TerrainVehicle, resolution: float, max_unknown_share: float,
           cover: float = 3.0) -> "VehicleArrays":
        """Return the arrays of `vehicle` on a grid of `resolution` [m]; `cover`: nodes per part width a bound reads."""
        w = np.array(vehicle.wheels, np.float64)
        ua0, ua1 = vehicle.axle_span
        hw = vehicle.body_half_width
        boxes = []
        for u0, u1 in ((ua0, 0.5 * (ua0 + ua1)), (0.5 * (ua0 + ua1), ua1)):
            boxes += [(u0, u1, 0.0, hw, vehicle.clearance, 0.0), (u0, u1, -hw, 0.0, vehicle.clearance, 0.0)]
        for u0, u1 in ((-vehicle.body_rear, ua0), (ua1, vehicle.body_front)):
            if u1 > u0:
                boxes += [(u0, u1, 0.0, hw, vehicle.overhang_clearance, 1.0),
                          (u0, u1, -hw, 0.0, vehicle.overhang_clearance, 1.0)]
        scalars = np.array([wheel_patch_on(vehicle, resolution), math.tan(vehicle.max_roll), math.tan(vehicle.max_pitch),
                            vehicle.max_step, allowed_unknown(vehicle, resolution, max_unknown_share),
                            float(w[:, 0] @ w[:, 0]), float(w[:, 1] @ w[:, 1]), cover], np.float64)
        u, v = w[:, 0], w[:, 1]
        moments = np.array([u @ u, v @ v, u @ v, (u ** 3).sum(), (u * u * v).sum(), (u * v * v).sum(), (v ** 3).sum()])
        return cls(w, moments, np.array(boxes, np.float64), np.array([-vehicle.body_rear, vehicle.body_front, -hw, hw]), scalars)


@njit(cache=True, nogil=True, boundscheck=False)
def _cos_range(a0: float, a1: float) -> tuple[float, float]:
    """Return (min, max) of cos over [a0, a1] [rad]."""
    lo = min(math.cos(a0), math.cos(a1))
    hi = max(math.cos(a0), math.cos(a1))
    if a1 - a0 >= 2.0 * math.pi:
        return -1.0, 1.0
    if math.floor(a1 / (2.0 * math.pi)) > math.floor(a0 / (2.0 * math.pi)):
        hi = 1.0
    if math.floor((a1 - math.pi) / (2.0 * math.pi)) > math.floor((a0 - math.pi) / (2.0 * math.pi)):
        lo = -1.0
    return lo, hi


@njit(cache=True, nogil=True, boundscheck=False)
def _part_level(extent: float, res: float, cover: float, levels: int) -> int:
    """Return the pyramid level whose nodes are about `extent` / `cover` [m] wide."""
    k = 0
    while k + 1 < levels and res * (1 << (k + 1)) <= extent / cover:
        k += 1
    return k


@njit(cache=True, nogil=True, boundscheck=False)
def _sweep(u0: float, u1: float, v0: float, v1: float, h: float, hth: float, wide: bool) -> tuple[float, float]:
    """Return (d, rmax) [m] for body box [u0, u1] × [v0, v1] over a voxel of half-size h [m], hth [rad].

    rmax is the box's farthest corner from the reference point. Narrow voxels: any point of the box
    stays within d = h·√2 + rmax·hth of where it is at the voxel's middle heading (chord ≤ arc).
    `wide` voxels: every point stays within rmax + d, d = h·√2, of the voxel's centre.
    """
    rmax = math.sqrt(max(u0 * u0, u1 * u1) + max(v0 * v0, v1 * v1))
    if wide:
        return h * math.sqrt(2.0), rmax
    return h * math.sqrt(2.0) + rmax * hth, rmax


@njit(cache=True, nogil=True, boundscheck=False)
def _nodes(u0: float, u1: float, v0: float, v1: float, xc: float, yc: float, c: float, s: float, d: float,
           rmax: float, disc_only: bool, k: int, res: float, dims: np.ndarray, offsets: np.ndarray,
           ny: int, nx: int, out: np.ndarray) -> tuple[int, int]:
    """Collect in `out` the level-k nodes the body box can reach over the voxel; return (nodes, cells off the grid).

    The count may exceed `out`'s length (then only what fits was written).

    The box, placed at (xc, yc) with heading cos c, sin s, grown by `d` [m] (or, with `disc_only`, the
    disc of radius rmax + d around (xc, yc) [m]). Node indices are rows of the pyramid's features.
    """
    if disc_only:
        x0, x1, y0, y1 = xc - rmax - d, xc + rmax + d, yc - rmax - d, yc + rmax + d
    else:
        x0 = x1 = xc + c * u0 - s * v0
        y0 = y1 = yc + s * u0 + c * v0
        for uu, vv in ((u0, v1), (u1, v0), (u1, v1)):
            px, py = xc + c * uu - s * vv, yc + s * uu + c * vv
            x0, x1, y0, y1 = min(x0, px), max(x1, px), min(y0, py), max(y1, py)
        x0, x1, y0, y1 = x0 - d, x1 + d, y0 - d, y1 + d
    # Cells whose centres the region holds, off the grid: they are unknown.
    ci0, ci1 = int(math.ceil(y0 / res - 0.5)), int(math.floor(y1 / res - 0.5))
    cj0, cj1 = int(math.ceil(x0 / res - 0.5)), int(math.floor(x1 / res - 0.5))
    off = 0
    if ci1 >= ci0 and cj1 >= cj0:
        inside = max(0, min(ci1, ny - 1) - max(ci0, 0) + 1) * max(0, min(cj1, nx - 1) - max(cj0, 0) + 1)
        off = (ci1 - ci0 + 1) * (cj1 - cj0 + 1) - inside
    side = res * (1 << k)
    h, w = dims[k, 0], dims[k, 1]
    i0, i1 = max(0, int(math.floor(y0 / side))), min(h - 1, int(math.floor(y1 / side)))
    j0, j1 = max(0, int(math.floor(x0 / side))), min(w - 1, int(math.floor(x1 / side)))
    half = side * 0.5 * math.sqrt(2.0)
    n = 0
    for i in range(i0, i1 + 1):
        yn = (i + 0.5) * side - yc
        for j in range(j0, j1 + 1):
            xn = (j + 0.5) * side - xc
            if disc_only:
                if xn * xn + yn * yn > (rmax + d + half) ** 2:
                    continue
            else:
                du, dv = c * xn + s * yn, -s * xn + c * yn
                if du < u0 - d - half or du > u1 + d + half or dv < v0 - d - half or dv > v1 + d + half:
                    continue
            if n < out.shape[0]:
                out[n] = offsets[k] + i * w + j
            n += 1
    return n, off


@njit(cache=True, nogil=True, boundscheck=False)
def _gather(u0: float, u1: float, v0: float, v1: float, xc: float, yc: float, c: float, s: float, d: float,
            rmax: float, wide: bool, extent: float, sc: np.ndarray, res: float, dims: np.ndarray, offsets: np.ndarray,
            ny: int, nx: int, out: np.ndarray) -> tuple[int, int, int]:
    """Return (level, nodes, cells off the grid) of `_nodes` at the level for `extent` [m], coarser while `out` is too small."""
    k = _part_level(extent, res, sc[S_COVER], dims.shape[0])
    while True:
        n, off = _nodes(u0, u1, v0, v1, xc, yc, c, s, d, rmax, wide, k, res, dims, offsets, ny, nx, out)
        if n <= out.shape[0] or k + 1 == dims.shape[0]:
            return k, min(n, out.shape[0]), off
        k += 1


@njit(cache=True, nogil=True, boundscheck=False)
def _solve(a: np.ndarray, b: np.ndarray, n: int) -> bool:
    """Solve the n×n system a·x = b in place (x left in b) by elimination with partial pivoting; False if singular."""
    scale = 0.0
    for i in range(n):
        scale = max(scale, abs(a[i, i]))
    for col in range(n):
        piv = col
        for r in range(col + 1, n):
            if abs(a[r, col]) > abs(a[piv, col]):
                piv = r
        if not abs(a[piv, col]) > 1e-10 * scale:
            return False
        if piv != col:
            for c in range(n):
                a[col, c], a[piv, c] = a[piv, c], a[col, c]
            b[col], b[piv] = b[piv], b[col]
        for r in range(col + 1, n):
            f = a[r, col] / a[col, col]
            for c in range(col, n):
                a[r, c] -= f * a[col, c]
            b[r] -= f * b[col]
    for col in range(n - 1, -1, -1):
        t = b[col]
        for c in range(col + 1, n):
            t -= a[col, c] * b[c]
        b[col] = t / a[col, col]
    return True


@njit(cache=True, nogil=True, boundscheck=False)
def _fit_surface(feat: np.ndarray, idx: np.ndarray, n: int, k: int, res: float, dims: np.ndarray, offsets: np.ndarray,
                 xc: float, yc: float, ext: float, q: np.ndarray) -> bool:
    """Fit Q(x, y) = z0 + gx·dx + gy·dy + ½hxx·dx² + hxy·dx·dy + ½hyy·dy² (dx = x − xc [m]) to level-k nodes `idx[:n]`.

    Writes (z0, gx, gy, hxx, hxy, hyy) into `q`: a count-weighted least-squares fit of the nodes' plane
    heights at their centres (in units of `ext` [m], about their spread, for the conditioning); a plane
    when too few nodes fix the curvature. False if no node is known.
    Any surface serves the bounds (they measure the terrain against it); a close one makes them tight.
    """
    side = res * (1 << k)
    w = dims[k, 1]
    a = np.zeros((6, 6))
    b = np.zeros(6)
    f = np.empty(6)
    known = 0
    zsum = wsum = 0.0
    for t in range(n):
        m = idx[t]
        cnt = feat[m, F_COUNT]
        if cnt == 0.0:
            continue
        local = m - offsets[k]
        dx, dy = ((local % w + 0.5) * side - xc) / ext, ((local // w + 0.5) * side - yc) / ext
        known += 1
        zsum += cnt * feat[m, F_PZ]
        wsum += cnt
        f[0], f[1], f[2], f[3], f[4], f[5] = 1.0, dx, dy, 0.5 * dx * dx, dx * dy, 0.5 * dy * dy
        for r in range(6):
            b[r] += cnt * f[r] * feat[m, F_PZ]
            for c in range(6):
                a[r, c] += cnt * f[r] * f[c]
    if known == 0:
        return False
    q[:] = 0.0
    b3 = b[:3].copy()  # the plane's normal equations are the quadratic's first three
    if known >= 9 and _solve(a.copy(), b, 6):
        q[0], q[1], q[2] = b[0], b[1] / ext, b[2] / ext
        q[3], q[4], q[5] = b[3] / ext ** 2, b[4] / ext ** 2, b[5] / ext ** 2
    elif known >= 3 and _solve(a[:3, :3].copy(), b3, 3):
        q[0], q[1], q[2] = b3[0], b3[1] / ext, b3[2] / ext
    else:
        q[0] = zsum / wsum
    return True


@njit(cache=True, nogil=True, boundscheck=False)
def _gap(feat: np.ndarray, m: int, i: int, j: int, k: int, res: float, ny: int, nx: int, q: np.ndarray, xc: float,
         yc: float) -> tuple[float, float]:
    """Return (above, below) [m]: how far node m's (level k, row i, col j) known cells can rise above / fall below Q.

    Its own distances to its plane plus how far that plane leaves Q over its cell centres (first
    order at the box's centre, plus Q's curvature over the box).
    """
    bb = 1 << k
    side = res * bb
    x0, x1 = (j * bb + 0.5) * res, (min((j + 1) * bb, nx) - 0.5) * res
    y0, y1 = (i * bb + 0.5) * res, (min((i + 1) * bb, ny) - 0.5) * res
    bx, by, ha, hb = 0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (x1 - x0), 0.5 * (y1 - y0)
    gxn, gyn = feat[m, F_PGX], feat[m, F_PGY]
    dx, dy = bx - xc, by - yc
    f0 = feat[m, F_PZ] + gxn * (bx - (j + 0.5) * side) + gyn * (by - (i + 0.5) * side) - (
        q[0] + q[1] * dx + q[2] * dy + 0.5 * q[3] * dx * dx + q[4] * dx * dy + 0.5 * q[5] * dy * dy)
    fx = gxn - (q[1] + q[3] * dx + q[4] * dy)
    fy = gyn - (q[2] + q[4] * dx + q[5] * dy)
    spread = abs(fx) * ha + abs(fy) * hb + 0.5 * (abs(q[3]) * ha * ha + 2.0 * abs(q[4]) * ha * hb + abs(q[5]) * hb * hb)
    return feat[m, F_ABOVE] + f0 + spread, feat[m, F_BELOW] - f0 + spread


@njit(cache=True, nogil=True, boundscheck=False)
def _residuals(feat: np.ndarray, idx: np.ndarray, n: int, k: int, res: float, dims: np.ndarray, offsets: np.ndarray,
               ny: int, nx: int, q: np.ndarray, xc: float, yc: float) -> tuple[float, float, float, float, float]:
    """Return (above, below, max discontinuity, known cells, unknown cells) of level-k nodes `idx[:n]` against Q.

    `above`/`below` [m] as `_gap`, over all the nodes (−inf when none is known).
    """
    above = below = disc = -np.inf
    known = unknown = 0.0
    w = dims[k, 1]
    for t in range(n):
        m = idx[t]
        cnt = feat[m, F_COUNT]
        known += cnt
        unknown += feat[m, F_CELLS] - cnt
        if cnt == 0.0:
            continue
        local = m - offsets[k]
        up, down = _gap(feat, m, local // w, local % w, k, res, ny, nx, q, xc, yc)
        above = max(above, up)
        below = max(below, down)
        disc = max(disc, feat[m, F_DISC])
    return above, below, disc, known, unknown


@njit(cache=True, nogil=True, boundscheck=False)
def _mul_range(a0: float, a1: float, b0: float, b1: float) -> tuple[float, float]:
    """Return the range of a·b for a in [a0, a1], b in [b0, b1]."""
    p0, p1, p2, p3 = a0 * b0, a0 * b1, a1 * b0, a1 * b1
    return min(min(p0, p1), min(p2, p3)), max(max(p0, p1), max(p2, p3))


@njit(cache=True, nogil=True, boundscheck=False)
def _sq_range(a0: float, a1: float) -> tuple[float, float]:
    """Return the range of a² for a in [a0, a1]."""
    lo = 0.0 if a0 <= 0.0 <= a1 else min(a0 * a0, a1 * a1)
    return lo, max(a0 * a0, a1 * a1)


@njit(cache=True, nogil=True, boundscheck=False)
def voxel_bounds(feat: np.ndarray, offsets: np.ndarray, dims: np.ndarray, res: float, ny: int, nx: int,
                 wheels: np.ndarray, moments: np.ndarray, boxes: np.ndarray, body: np.ndarray, sc: np.ndarray,
                 xc: float, yc: float, h: float, th: float, hth: float, scratch: np.ndarray,
                 counts: np.ndarray) -> tuple[int, int, int]:
    """Classify the voxel |x − xc|, |y − yc| ≤ h [m], |θ − th| ≤ hth [rad] (x, y from the grid's origin).

    Return (ADMISSIBLE / INADMISSIBLE / MIXED, bits of the constraints that fail for every
    configuration, bits of those no bound decides — the first found: a mixed voxel stops the reading). `scratch` is an int64 work array; the nodes read
    are added to `counts[0]`.

    The terrain is written as a quadratic surface Q fitted to the nodes under the body, plus residuals
    bounded part by part. With wheel heights Q(pᵢ) + eᵢ, tan(pitch) = ∇Q·û + Σuᵢeᵢ/Σuᵢ² (+ Q's
    curvature against the wheels' third moments), and a cell's rise above the wheels' plane is
    K(u, v, θ) + r − Σαᵢeᵢ, K the curvature term ½[wᵀH_b w − Σαᵢ wᵢᵀH_b wᵢ] (H_b: Q's Hessian in
    `vehicle`, w = (u, v)): Q's affine part cancels, as the plane through the wheels reproduces it.
    """
    c, s = math.cos(th), math.sin(th)
    wide = hth >= 0.5 * math.pi
    fail = 0
    mixed = 0
    nw = wheels.shape[0]
    q = np.empty(6)
    d, rmax = _sweep(body[0], body[1], body[2], body[3], h, hth, wide)
    # Q needs only a few nodes across the body (twice as coarse as the parts read).
    k, n, off_grid = _gather(body[0], body[1], body[2], body[3], xc, yc, c, s, d, rmax, wide,
                             2.0 * (min(body[1] - body[0], body[3] - body[2]) + 2.0 * d), sc, res, dims, offsets, ny, nx,
                             scratch)
    counts[0] += n
    unknown = float(off_grid)
    for t in range(n):
        unknown += feat[scratch[t], F_CELLS] - feat[scratch[t], F_COUNT]
    if not _fit_surface(feat, scratch, n, k, res, dims, offsets, xc, yc, rmax + d, q):
        return INADMISSIBLE, B_SENSING, 0
    sensing_ok = unknown <= sc[S_ALLOWED]
    g0 = math.sqrt(q[1] * q[1] + q[2] * q[2])
    hn = math.sqrt(q[3] * q[3] + 2.0 * q[4] * q[4] + q[5] * q[5])  # ≥ |H| (Frobenius)
    patch = sc[S_PATCH]
    # Each wheel's height is Q at its contact point plus e in [-(below + eg), above + eg], eg how far Q
    # itself rises within the patch.
    e_lo = np.empty(nw)
    e_hi = np.empty(nw)
    step_ok = True
    for i in range(nw):
        u, v = wheels[i, 0], wheels[i, 1]
        d, rmax = _sweep(u, u, v, v, h, hth, wide)
        reach = rmax + d if wide else math.sqrt(u * u + v * v) + d
        d += patch
        k, n, off_grid = _gather(u, u, v, v, xc, yc, c, s, d, rmax, wide, 2.0 * d, sc, res, dims, offsets, ny, nx, scratch)
        counts[0] += n
        above, below, disc, known, unk = _residuals(feat, scratch, n, k, res, dims, offsets, ny, nx, q, xc, yc)
        if unk + off_grid > 0.0:
            sensing_ok = False
        eg = (g0 + hn * reach) * patch + 0.5 * hn * patch * patch
        if known == 0.0:
            e_lo[i], e_hi[i] = -np.inf, np.inf
        else:
            e_lo[i], e_hi[i] = -(below + eg), above + eg
        if disc > sc[S_STEP]:
            step_ok = False
    if not sensing_ok:
        mixed |= B_SENSING
    if not step_ok:
        mixed |= B_COLLIDE
    # Q's Hessian in `vehicle` over the heading interval: huu = m + ρ·cos(2θ − ψ), hvv = m − ρ·cos(2θ − ψ),
    # huv = ρ·cos(2θ − ψ + π/2).
    hm = 0.5 * (q[3] + q[5])
    hr = math.sqrt((0.5 * (q[3] - q[5])) ** 2 + q[4] * q[4])
    psi = math.atan2(q[4], 0.5 * (q[3] - q[5]))
    c2lo, c2hi = _cos_range(2.0 * (th - hth) - psi, 2.0 * (th + hth) - psi)
    s2lo, s2hi = _cos_range(2.0 * (th - hth) - psi + 0.5 * math.pi, 2.0 * (th + hth) - psi + 0.5 * math.pi)
    huu_lo, huu_hi = hm + hr * c2lo, hm + hr * c2hi
    hvv_lo, hvv_hi = hm - hr * c2hi, hm - hr * c2lo
    huv_lo, huv_hi = hr * s2lo, hr * s2hi
    # Tip-over: tan(pitch) = ∇Q(position)·û + Σuᵢeᵢ/Σuᵢ² + (huu·Σu³ + 2huv·Σu²v + hvv·Σuv²)/(2Σu²); roll alike.
    phi = math.atan2(q[2], q[1])
    pu_lo, pu_hi = _cos_range(th - hth - phi, th + hth - phi)
    pv_lo, pv_hi = _cos_range(th - hth - phi + 0.5 * math.pi, th + hth - phi + 0.5 * math.pi)
    move = hn * h * math.sqrt(2.0)  # how far ∇Q changes over the voxel's positions
    tp_lo, tp_hi = g0 * pu_lo - move, g0 * pu_hi + move
    tr_lo, tr_hi = g0 * pv_lo - move, g0 * pv_hi + move
    su3, su2v, suv2, sv3 = moments[3], moments[4], moments[5], moments[6]
    for hl, hh, mu, mv in ((huu_lo, huu_hi, su3, su2v), (huv_lo, huv_hi, 2.0 * su2v, 2.0 * suv2), (hvv_lo, hvv_hi, suv2, sv3)):
        lo, hi = _mul_range(hl, hh, mu, mu)
        tp_lo, tp_hi = tp_lo + 0.5 * lo / sc[S_SUU], tp_hi + 0.5 * hi / sc[S_SUU]
        lo, hi = _mul_range(hl, hh, mv, mv)
        tr_lo, tr_hi = tr_lo + 0.5 * lo / sc[S_SVV], tr_hi + 0.5 * hi / sc[S_SVV]
    for i in range(nw):
        u, v = wheels[i, 0], wheels[i, 1]
        if u != 0.0:
            tp_lo += min(u * e_lo[i], u * e_hi[i]) / sc[S_SUU]
            tp_hi += max(u * e_lo[i], u * e_hi[i]) / sc[S_SUU]
        if v != 0.0:
            tr_lo += min(v * e_lo[i], v * e_hi[i]) / sc[S_SVV]
            tr_hi += max(v * e_lo[i], v * e_hi[i]) / sc[S_SVV]
    if tp_lo > sc[S_TAN_PITCH] or tp_hi < -sc[S_TAN_PITCH] or tr_lo > sc[S_TAN_ROLL] or tr_hi < -sc[S_TAN_ROLL]:
        fail |= B_TIP
    elif not (tp_lo >= -sc[S_TAN_PITCH] and tp_hi <= sc[S_TAN_PITCH] and tr_lo >= -sc[S_TAN_ROLL]
              and tr_hi <= sc[S_TAN_ROLL]):
        mixed |= B_TIP
    # Only tip-over and sensing can fail for every configuration: once the class is settled, stop reading.
    if fail:
        return INADMISSIBLE, fail, mixed
    if mixed:
        return MIXED, 0, mixed
    # Body parts: rise = K + r − Σαᵢeᵢ with αᵢ(u, v) = 1/n + u·uᵢ/Σu² + v·vᵢ/Σv²; the worst Σ over a part
    # lies at one of its corners; K is bounded term by term over the part and the heading interval.
    # One pass over the nodes the body can reach: each node's rise above Q goes to every part it may touch.
    nb = boxes.shape[0]
    part_above = np.full(nb, -np.inf)
    d, rmax = _sweep(body[0], body[1], body[2], body[3], h, hth, wide)
    extent = np.inf
    for b in range(nb):
        extent = min(extent, min(boxes[b, 1] - boxes[b, 0], boxes[b, 3] - boxes[b, 2]))
    k, n, off_grid = _gather(body[0], body[1], body[2], body[3], xc, yc, c, s, d, rmax, wide, extent + 2.0 * d, sc, res,
                             dims, offsets, ny, nx, scratch)
    counts[0] += n
    w = dims[k, 1]
    side = res * (1 << k)
    half = side * 0.5 * math.sqrt(2.0)
    reach = np.empty(nb)  # wide: how far from the centre a part's nodes may lie; narrow: how far outside the part
    for b in range(nb):
        db, dp = _sweep(boxes[b, 0], boxes[b, 1], boxes[b, 2], boxes[b, 3], h, hth, wide)
        reach[b] = (dp + db + half) ** 2 if wide else db + half
    for t in range(n):
        m = scratch[t]
        if feat[m, F_COUNT] == 0.0:
            continue
        local = m - offsets[k]
        i, j = local // w, local % w
        xn, yn = (j + 0.5) * side - xc, (i + 0.5) * side - yc
        du, dv = c * xn + s * yn, -s * xn + c * yn
        up = np.nan
        for b in range(nb):
            if wide:
                if xn * xn + yn * yn > reach[b]:
                    continue
            elif (du < boxes[b, 0] - reach[b] or du > boxes[b, 1] + reach[b] or dv < boxes[b, 2] - reach[b]
                  or dv > boxes[b, 3] + reach[b]):
                continue
            if up != up:
                up, _ = _gap(feat, m, i, j, k, res, ny, nx, q, xc, yc)
            part_above[b] = max(part_above[b], up)
    for b in range(nb):
        u0, u1, v0, v1 = boxes[b, 0], boxes[b, 1], boxes[b, 2], boxes[b, 3]
        bit = B_HIGH if boxes[b, 5] == 0.0 else B_COLLIDE
        above = part_above[b]
        if above == -np.inf:
            continue
        worst = -np.inf
        for cu in (u0, u1):
            for cv in (v0, v1):
                t = 0.0
                for i in range(nw):
                    a = 1.0 / nw + cu * wheels[i, 0] / sc[S_SUU] + cv * wheels[i, 1] / sc[S_SVV]
                    t += a * -e_lo[i] if a >= 0.0 else -a * e_hi[i]
                worst = max(worst, t)
        # K's coefficients over the part: Cuu = ½(u² − Σαᵢuᵢ²), Cuv = uv − Σαᵢuᵢvᵢ, Cvv = ½(v² − Σαᵢvᵢ²);
        # Σαᵢ·(moment) is affine in (u, v): its range is the corners'.
        uu_lo, uu_hi = _sq_range(u0, u1)
        vv_lo, vv_hi = _sq_range(v0, v1)
        uv_lo, uv_hi = _mul_range(u0, u1, v0, v1)
        kk = 0.0
        for moment, m_u, m_v, x_lo, x_hi, scale, hl, hh in (
                (moments[0], moments[3], moments[4], uu_lo, uu_hi, 0.5, huu_lo, huu_hi),
                (moments[2], moments[4], moments[5], uv_lo, uv_hi, 1.0, huv_lo, huv_hi),
                (moments[1], moments[5], moments[6], vv_lo, vv_hi, 0.5, hvv_lo, hvv_hi)):
            a_lo = a_hi = moment / nw + u0 * m_u / sc[S_SUU] + v0 * m_v / sc[S_SVV]
            for cu in (u0, u1):
                for cv in (v0, v1):
                    a = moment / nw + cu * m_u / sc[S_SUU] + cv * m_v / sc[S_SVV]
                    a_lo, a_hi = min(a_lo, a), max(a_hi, a)
            lo, hi = _mul_range(hl, hh, scale * (x_lo - a_hi), scale * (x_hi - a_lo))
            kk += hi
        if not kk + above + worst <= boxes[b, 4]:
            return MIXED, 0, bit
    return ADMISSIBLE, 0, 0


@njit(cache=True, nogil=True, boundscheck=False)
def configuration_bits(feat: np.ndarray, offsets: np.ndarray, dims: np.ndarray, res: float, ny: int, nx: int,
                       wheels: np.ndarray, boxes: np.ndarray, body: np.ndarray, sc: np.ndarray, x: float, y: float,
                       th: float) -> int:
    """Return the bits of the constraints configuration (x, y [m] from the grid's origin, θ [rad]) violates, cell by cell.

    The compiled twin of `evaluate_configuration`, on the pyramid's level-0 nodes (one per cell): the
    exact answer at the pixel resolution where the voxel bounds are too loose to decide.
    """
    c, s = math.cos(th), math.sin(th)
    w0 = dims[0, 1]
    base = offsets[0]
    nw = wheels.shape[0]
    ua0, ua1 = wheels[0, 0], wheels[0, 0]
    for k in range(nw):
        ua0, ua1 = min(ua0, wheels[k, 0]), max(ua1, wheels[k, 0])
    belly_clear, over_clear = np.inf, np.inf
    for b in range(boxes.shape[0]):
        if boxes[b, 5] == 0.0:
            belly_clear = min(belly_clear, boxes[b, 4])
        else:
            over_clear = min(over_clear, boxes[b, 4])
    reach = math.hypot(max(-body[0], body[1]), max(-body[2], body[3])) + res
    i0, i1 = int(math.floor((y - reach) / res)), int(math.floor((y + reach) / res))
    patch = sc[S_PATCH]
    # Each row's cells span only the x the body's rectangle covers there (a scan line), grown by a cell.
    cu = np.array([body[0], body[1], body[1], body[0]])
    cv = np.array([body[2], body[2], body[3], body[3]])
    px = x + c * cu - s * cv
    py = y + s * cu + c * cv
    span = np.empty((i1 - i0 + 1, 2), np.int64)
    for r in range(i1 - i0 + 1):
        yc = (i0 + r + 0.5) * res
        lo, hi = np.inf, -np.inf
        for e in range(4):
            ax, ay, bx, by = px[e], py[e], px[(e + 1) % 4], py[(e + 1) % 4]
            ya, yb = min(ay, by) - res, max(ay, by) + res
            if yc < ya or yc > yb:
                continue
            if abs(by - ay) < 1e-12:
                lo, hi = min(lo, ax, bx), max(hi, ax, bx)
            else:
                t = min(max((yc - ay) / (by - ay), 0.0), 1.0)
                xe = ax + t * (bx - ax)
                lo, hi = min(lo, xe), max(hi, xe)
        if lo > hi:
            span[r, 0], span[r, 1] = 1, 0
        else:
            # grown by two cells: a wheel patch may reach past the body's edge
            span[r, 0] = int(math.floor((lo - 2.0 * res) / res))
            span[r, 1] = int(math.floor((hi + 2.0 * res) / res))
    zw = np.full(nw, -np.inf)
    step = 0.0
    # Each wheel reads only the cells of its own patch (those of the scan lines above that lie within its reach).
    for k in range(nw):
        wx = x + c * wheels[k, 0] - s * wheels[k, 1]
        wy = y + s * wheels[k, 0] + c * wheels[k, 1]
        for i in range(max(i0, int(math.floor((wy - patch) / res)) - 1), min(i1, int(math.floor((wy + patch) / res)) + 1) + 1):
            if not 0 <= i < ny:
                continue
            j_lo = max(span[i - i0, 0], int(math.floor((wx - patch) / res)) - 1, 0)
            j_hi = min(span[i - i0, 1], int(math.floor((wx + patch) / res)) + 1, nx - 1)
            for j in range(j_lo, j_hi + 1):
                m = base + i * w0 + j
                if not feat[m, F_COUNT] > 0.0:
                    continue
                cx, cy = (j + 0.5) * res - x, (i + 0.5) * res - y
                u, v = c * cx + s * cy, -s * cx + c * cy
                if math.hypot(u - wheels[k, 0], v - wheels[k, 1]) <= patch:
                    zw[k] = max(zw[k], feat[m, F_ZMAX])
                    d = feat[m, F_DISC]
                    if d == d:
                        step = max(step, d)
    bits = 0
    if step > sc[S_STEP]:
        bits |= B_COLLIDE
    for k in range(nw):
        if zw[k] == -np.inf:
            return bits | B_SENSING
    zbar = 0.0
    tp = tr = 0.0
    for k in range(nw):
        zbar += zw[k] / nw
        tp += wheels[k, 0] * zw[k] / sc[S_SUU]
        tr += wheels[k, 1] * zw[k] / sc[S_SVV]
    if abs(tp) > sc[S_TAN_PITCH] or abs(tr) > sc[S_TAN_ROLL]:
        bits |= B_TIP
    # One pass over the body's cells: the unknown ones (off the grid too) and the known ones' rise over the wheels' plane.
    unknown = 0.0
    for i in range(i0, i1 + 1):
        for j in range(span[i - i0, 0], span[i - i0, 1] + 1):
            cx, cy = (j + 0.5) * res - x, (i + 0.5) * res - y
            u, v = c * cx + s * cy, -s * cx + c * cy
            if not (body[0] <= u <= body[1] and body[2] <= v <= body[3]):
                continue
            m = base + i * w0 + j
            if not (0 <= i < ny and 0 <= j < nx and feat[m, F_COUNT] > 0.0):
                unknown += 1.0
                continue
            rise = feat[m, F_ZMAX] - (zbar + u * tp + v * tr)
            if ua0 <= u <= ua1:
                if rise > belly_clear:
                    bits |= B_HIGH
            elif rise > over_clear:
                bits |= B_COLLIDE
    if unknown > sc[S_ALLOWED]:
        bits |= B_SENSING
    return bits
