"""The bucket elevation map (Navlab 1990 §2.3.2, Figure 2.7): 3-D points registered by the pose estimate into grid cells.

Each valid pixel of a range image becomes a point in `world` (the pose estimate world ← vehicle and
the mount vehicle ← laser); each cell's height is the mean height of the points that fall in it,
its sigma the points' spread within the cell combined with their own: a point's range sigma moves
it along its ray, so its height by sigma·|d_z|. Cells no point fell in are unknown (NaN, sigma inf),
whether never seen or merely between sparse samples (the difficulty of §2.3.5 that the locus
method answers).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.grid_spec import GridSpec
from modules.terrain.range_image import RangeImage

__all__ = ["bucket_map", "bucket_points"]


@njit(cache=True, nogil=True, boundscheck=False)
def _buckets(pts: np.ndarray, sz: np.ndarray, ox: float, oy: float, res: float, ny: int, nx: int
             ) -> tuple[np.ndarray, np.ndarray]:
    n = np.zeros((ny, nx), np.int32)
    s1 = np.zeros((ny, nx))
    s2 = np.zeros((ny, nx))
    m2 = np.zeros((ny, nx))
    inv = 1.0 / res
    for k in range(pts.shape[0]):
        z = pts[k, 2]
        if not z == z:
            continue
        j = int(np.floor((pts[k, 0] - ox) * inv))
        i = int(np.floor((pts[k, 1] - oy) * inv))
        if 0 <= i < ny and 0 <= j < nx:
            n[i, j] += 1
            s1[i, j] += z
            s2[i, j] += z * z
            m2[i, j] += sz[k] * sz[k]
    mean = np.full((ny, nx), np.nan, np.float32)
    sigma = np.full((ny, nx), np.inf, np.float32)
    for i in range(ny):
        for j in range(nx):
            c = n[i, j]
            if c:
                mu = s1[i, j] / c
                mean[i, j] = mu
                sigma[i, j] = np.sqrt(max(s2[i, j] / c - mu * mu, 0.0) + m2[i, j] / (c * c))
    return mean, sigma


def bucket_points(points: np.ndarray, sigma_z: np.ndarray, spec: GridSpec) -> ElevationGrid:
    """Return the bucket map of points (N, 3) [m] with height sigmas (N,) [m], in `spec`'s frame, on the grid `spec`."""
    pts = np.ascontiguousarray(np.asarray(points, np.float64).reshape(-1, 3))
    sz = np.ascontiguousarray(np.asarray(sigma_z, np.float64).reshape(-1))
    mean, sigma = _buckets(pts, sz, spec.origin_x, spec.origin_y, spec.resolution, spec.ny, spec.nx)
    return ElevationGrid(spec.origin_x, spec.origin_y, spec.resolution, mean, sigma, spec.frame)


def bucket_map(image: RangeImage, world_from_vehicle: np.ndarray, spec: GridSpec, *, max_range: float = 20.0) -> ElevationGrid:
    """Return the bucket map of one range image (points within `max_range` [m] horizontally of the sensor) on `spec`."""
    T = image.world_from_laser(world_from_vehicle)
    d = image.directions() @ T[:3, :3].T
    valid = image.valid
    r = image.range[valid].astype(np.float64)
    dv = d[valid]
    pts = T[:3, 3] + dv * r[:, None]
    near = np.hypot(pts[:, 0] - T[0, 3], pts[:, 1] - T[1, 3]) <= max_range
    return bucket_points(pts[near], (image.sigma[valid].astype(np.float64) * np.abs(dv[:, 2]))[near], spec)
