"""The ground under the vehicle, known from its wheels and its inclinometer, not from the laser.

The ERIM cannot see the ground under the vehicle nor, at the bottom of its 30° elevation window, the
first few metres ahead of the bumper: a locus map starts some 5–6 m ahead of the Navlab. Yet the
vehicle stands on that ground: its wheels rest on it, so the plane through their contacts is the
vehicle's own plane — its height the pose's z, its slope the inclinometer's roll and pitch — and the
ground under the belly lies below that plane plus the clearance (else it would be high-centred).

The pose is the vehicle's pose frame (the Navlab's: its rear axle); the body lies around the reference point
`reference_ahead` in front of it. `footprint_heights` writes that plane into the *unknown* cells of the body's rectangle (cells the laser
measured keep their heights), with a standard deviation `sigma` [m] that says it is an assumption, not
a measurement. `ahead` [m] extends the rectangle beyond the bumper: at the start of a drive the
vehicle has seen nothing there yet, and it can neither plan nor move without a premise about it; the
premise is that the ground continues the plane the vehicle stands on up to where the laser takes over
(the vehicle was set down facing ground it can drive). Frames: the grid's (`world`); the vehicle's
u forward, v left [m].
"""

from __future__ import annotations

import math

import numpy as np

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.vehicle_model import TerrainVehicle
from modules.terrain.vehicle_pose import VehiclePose

__all__ = ["footprint_heights", "FOOTPRINT_SIGMA_M", "FOOTPRINT_MARGIN_M"]

#: The standard deviation [m] of a footprint cell: about half the Navlab's belly clearance, the most the
#: ground under the body can lie off the wheels' plane without the vehicle noticing.
FOOTPRINT_SIGMA_M = 0.1
#: How far [m] the footprint reaches beyond the body: the planner grows its voxels by the control
#: uncertainty and half a motion's sampling step, so the configuration the vehicle stands in reads that far.
FOOTPRINT_MARGIN_M = 0.5


def footprint_heights(grid: ElevationGrid, pose: VehiclePose, vehicle: TerrainVehicle, *, ahead: float = 0.0,
                      margin: float = FOOTPRINT_MARGIN_M, sigma: float = FOOTPRINT_SIGMA_M) -> tuple[int, int, int, int] | None:
    """Write the vehicle's plane at `pose` into the unknown cells under its body grown by `margin` [m] (and `ahead` [m] beyond its front).

    Changes `grid` in place; return the block (i0, i1, j0, j1) of rows and columns it looked at, or None
    when the body lies off the grid.
    """
    r = grid.resolution
    ny, nx = grid.shape
    front = vehicle.body_front + max(ahead, 0.0) + margin
    rear, half = vehicle.body_rear + margin, vehicle.body_half_width + margin
    reach = math.hypot(max(rear, front), half) + abs(vehicle.reference_ahead) + r
    i0, j0 = grid.cell_of(pose.x - reach, pose.y - reach)
    i1, j1 = grid.cell_of(pose.x + reach, pose.y + reach)
    i0, j0, i1, j1 = max(i0, 0), max(j0, 0), min(i1 + 1, ny), min(j1 + 1, nx)
    if i1 <= i0 or j1 <= j0:
        return None
    cx = grid.origin_x + (np.arange(j0, j1) + 0.5) * r - pose.x
    cy = grid.origin_y + (np.arange(i0, i1) + 0.5) * r - pose.y
    dx, dy = np.meshgrid(cx, cy)
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    u, v = c * dx + s * dy - vehicle.reference_ahead, -s * dx + c * dy  # u from the reference point, the body's origin
    inside = (u >= -rear) & (u <= front) & (np.abs(v) <= half)
    n = pose.rotation()[:, 2]  # the vehicle's up axis: the normal of the wheels' plane, through (x, y, z)
    plane = pose.z - (n[0] * dx + n[1] * dy) / max(n[2], 1e-6)
    zb, sb = grid.z[i0:i1, j0:j1], grid.sigma[i0:i1, j0:j1]
    fill = inside & np.isnan(zb)
    zb[fill] = plane[fill].astype(np.float32)
    sb[fill] = np.float32(sigma)
    return i0, i1, j0, j1
