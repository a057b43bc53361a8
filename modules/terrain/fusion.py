"""Fusion of the elevation maps of consecutive images (Navlab 1990 §2.3.3).

Each image's map is already registered in x, y, roll, pitch and yaw by the pose estimate it was
built with; what the estimate leaves, the height, is registered "by calculating the z offset between
maps as the mean difference of z values" over the cells both know. The maps are then merged cell by
cell, each known height weighted by the inverse of its variance (a cell known to one map only takes
that map's; a sigma below `sigma_floor` counts as the floor, so that no image can freeze a cell). Frames: both maps in one frame, on one lattice (`GridSpec.offset_in`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import TerrainError
from modules.terrain.grid_spec import GridSpec

__all__ = ["ZOffset", "z_offset", "fuse"]


@dataclass(frozen=True)
class ZOffset:
    """The height to add to a new map [m] so it meets the old one, and over how many common cells it was found."""

    dz: float
    cells: int


@njit(cache=True, nogil=True, boundscheck=False)
def _mean_difference(zo: np.ndarray, zn: np.ndarray) -> tuple[float, int]:
    total, n = 0.0, 0
    for i in range(zo.shape[0]):
        for j in range(zo.shape[1]):
            a, b = zo[i, j], zn[i, j]
            if a == a and b == b:
                total += a - b
                n += 1
    return (total / n if n else 0.0), n


@njit(cache=True, nogil=True, boundscheck=False)
def _merge(zo: np.ndarray, so: np.ndarray, zn: np.ndarray, sn: np.ndarray, dz: float, floor: float
           ) -> tuple[np.ndarray, np.ndarray]:
    ny, nx = zo.shape
    z = np.empty((ny, nx), np.float32)
    s = np.empty((ny, nx), np.float32)
    f2 = floor * floor
    for i in range(ny):
        for j in range(nx):
            a, b = zo[i, j], zn[i, j]
            if a == a and b == b:
                wa = 1.0 / max(so[i, j] * so[i, j], f2)
                wb = 1.0 / max(sn[i, j] * sn[i, j], f2)
                z[i, j] = (a * wa + (b + dz) * wb) / (wa + wb)
                s[i, j] = 1.0 / np.sqrt(wa + wb)
            elif a == a:
                z[i, j], s[i, j] = a, so[i, j]
            elif b == b:
                z[i, j], s[i, j] = b + dz, sn[i, j]
            else:
                z[i, j], s[i, j] = np.nan, np.inf
    return z, s


def z_offset(new: ElevationGrid, old: ElevationGrid, *, min_cells: int = 50) -> ZOffset:
    """Return the mean of old − new over the cells both know (0 over fewer than `min_cells`); both on one geometry."""
    if GridSpec.of(new) != GridSpec.of(old):
        raise TerrainError("z registration needs two maps of one geometry (take one into the other's first)")
    dz, n = _mean_difference(old.z, new.z)
    return ZOffset(float(dz) if n >= min_cells else 0.0, int(n))


def fuse(old: ElevationGrid, new: ElevationGrid, *, register_z: bool = True, min_cells: int = 50, sigma_floor: float = 0.01
         ) -> tuple[ElevationGrid, ZOffset]:
    """Return `new` fused into `old` (same geometry), after registering it in z when asked, and the offset applied."""
    off = z_offset(new, old, min_cells=min_cells) if register_z else ZOffset(0.0, 0)
    if GridSpec.of(new) != GridSpec.of(old):
        raise TerrainError("fusion needs two maps of one geometry (take one into the other's first)")
    z, sigma = _merge(old.z, old.sigma, new.z, new.sigma, off.dz, sigma_floor)
    return ElevationGrid(old.origin_x, old.origin_y, old.resolution, z, sigma, old.frame), off
