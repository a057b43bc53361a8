"""A brute-force check of one configuration on an elevation grid, written apart from the planner's code.

It restates the constraints of `modules.terrain.constraints` from their definitions, cell by cell:
the discontinuity from the grid's height differences, the wheels' plane by least squares, every
cell under the body against it. The tests hold the planner's paths and voxels to it.
"""

from __future__ import annotations

import math

import numpy as np

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.vehicle_model import TerrainVehicle


def discontinuity(z: np.ndarray) -> np.ndarray:
    """Return each cell's discontinuity [m]: per axis, the larger jump beside it less what the minmod slope explains."""
    out = np.zeros(z.shape)
    for axis in (0, 1):
        zz = np.moveaxis(z.astype(np.float64), axis, 0)
        back = np.full(zz.shape, np.nan)
        fwd = np.full(zz.shape, np.nan)
        back[1:] = zz[1:] - zz[:-1]
        fwd[:-1] = zz[1:] - zz[:-1]
        with np.errstate(invalid="ignore"):
            minmod = np.where(back * fwd > 0, np.where(np.abs(back) < np.abs(fwd), back, fwd), 0.0)
            jump = np.maximum(np.abs(back), np.abs(fwd)) - np.abs(minmod)
        jump = np.where(np.isnan(back) | np.isnan(fwd), 0.0, jump)
        out = np.maximum(out, np.moveaxis(jump, 0, axis))
    return out


def violations(grid: ElevationGrid, disc: np.ndarray, vehicle: TerrainVehicle, x: float, y: float, theta: float,
               max_unknown_share: float = 0.0) -> set[str]:
    """Return the names of the constraints configuration (x, y, θ) violates on `grid` (`disc` from `discontinuity`)."""
    r = grid.resolution
    ny, nx = grid.shape
    c, s = math.cos(theta), math.sin(theta)
    out: set[str] = set()
    body = []  # (u, v, z or nan, disc)
    reach = math.hypot(max(vehicle.body_rear, vehicle.body_front), vehicle.body_half_width) + r
    for i in range(int((y - reach - grid.origin_y) // r), int((y + reach - grid.origin_y) // r) + 1):
        for j in range(int((x - reach - grid.origin_x) // r), int((x + reach - grid.origin_x) // r) + 1):
            px, py = grid.origin_x + (j + 0.5) * r - x, grid.origin_y + (i + 0.5) * r - y
            u, v = c * px + s * py, -s * px + c * py
            inside = 0 <= i < ny and 0 <= j < nx
            body.append((u, v, float(grid.z[i, j]) if inside else math.nan, float(disc[i, j]) if inside else 0.0))
    cells = np.array(body)
    u, v, z, d = cells.T
    under = (u >= -vehicle.body_rear) & (u <= vehicle.body_front) & (np.abs(v) <= vehicle.body_half_width)
    area = (vehicle.body_rear + vehicle.body_front) * 2.0 * vehicle.body_half_width
    if np.count_nonzero(under & np.isnan(z)) > math.floor(max_unknown_share * area / r ** 2 + 1e-9):
        out.add("sensing")
    patch = max(vehicle.wheel_patch, r * math.sqrt(0.5) * 1.0001)
    contacts = []
    for wu, wv in vehicle.wheels:
        near = (np.hypot(u - wu, v - wv) <= patch) & ~np.isnan(z)
        if not near.any():
            out.add("sensing")
            return out
        contacts.append((wu, wv, z[near].max()))
        if d[near].max() > vehicle.max_step:
            out.add("collision")
    w = np.array(contacts)
    a, bu, bv = np.linalg.lstsq(np.column_stack([np.ones(len(w)), w[:, 0], w[:, 1]]), w[:, 2], rcond=None)[0]
    if abs(math.atan(bu)) > vehicle.max_pitch or abs(math.atan(bv)) > vehicle.max_roll:
        out.add("tip-over")
    rise = z - (a + bu * u + bv * v)
    lo, hi = min(wu for wu, _ in vehicle.wheels), max(wu for wu, _ in vehicle.wheels)
    belly = under & (u >= lo) & (u <= hi) & ~np.isnan(z)
    ends = under & ~((u >= lo) & (u <= hi)) & ~np.isnan(z)
    if belly.any() and rise[belly].max() > vehicle.clearance:
        out.add("high-centring")
    if ends.any() and rise[ends].max() > vehicle.overhang_clearance:
        out.add("collision")
    return out
