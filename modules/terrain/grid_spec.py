"""Where an elevation map lies: the geometry of an `ElevationGrid` (origin, cell size, rows and columns, frame).

Cell (row i, column j) covers x ∈ [origin_x + j·resolution, …+resolution), y ∈ [origin_y + i·resolution, …),
as in `ElevationGrid`. Grids on one lattice (origins a whole number of cells apart, equal resolution)
can be fused and moved into one another cell for cell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import TerrainError

__all__ = ["GridSpec"]


@dataclass(frozen=True)
class GridSpec:
    """A grid of `ny` × `nx` cells of `resolution` [m] with its lower-left corner at (origin_x, origin_y) [m] in `frame`."""

    origin_x: float
    origin_y: float
    resolution: float
    ny: int
    nx: int
    frame: str = "world"

    def __post_init__(self) -> None:
        if not self.resolution > 0.0 or self.ny < 1 or self.nx < 1:
            raise TerrainError(f"a grid needs resolution > 0 m and at least one cell, got {self.resolution} m, {self.ny}×{self.nx}")

    @classmethod
    def of(cls, grid: ElevationGrid) -> "GridSpec":
        """Return the geometry of an elevation grid."""
        ny, nx = grid.shape
        return cls(grid.origin_x, grid.origin_y, grid.resolution, ny, nx, grid.frame)

    @classmethod
    def around(cls, x: float, y: float, yaw: float, *, ahead: float, behind: float, side: float, resolution: float,
               frame: str = "world") -> "GridSpec":
        """Return the axis-aligned grid, on the lattice of `resolution` [m] through (0, 0), covering the rectangle from
        `behind` [m] back to `ahead` [m] forward and `side` [m] to each side of a vehicle at (x, y) [m], heading `yaw` [rad]."""
        c, s = math.cos(yaw), math.sin(yaw)
        corners = np.array([[ahead, side], [ahead, -side], [-behind, side], [-behind, -side]])
        xs = x + c * corners[:, 0] - s * corners[:, 1]
        ys = y + s * corners[:, 0] + c * corners[:, 1]
        j0, i0 = math.floor(xs.min() / resolution), math.floor(ys.min() / resolution)
        j1, i1 = math.ceil(xs.max() / resolution), math.ceil(ys.max() / resolution)
        return cls(j0 * resolution, i0 * resolution, resolution, int(i1 - i0), int(j1 - j0), frame)

    @property
    def shape(self) -> tuple[int, int]:
        """Return (ny, nx)."""
        return (self.ny, self.nx)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the cell centres' x (nx,) and y (ny,) [m], float64."""
        return (self.origin_x + (np.arange(self.nx) + 0.5) * self.resolution,
                self.origin_y + (np.arange(self.ny) + 0.5) * self.resolution)

    def unknown(self) -> ElevationGrid:
        """Return an elevation grid of this geometry with no cell known."""
        return ElevationGrid.unknown(self.origin_x, self.origin_y, self.resolution, self.ny, self.nx, self.frame)

    def offset_in(self, other: "GridSpec") -> tuple[int, int]:
        """Return (rows, columns) from `other`'s cell (0, 0) to this grid's, on a common lattice (TerrainError otherwise)."""
        if abs(self.resolution - other.resolution) > 1e-9 * self.resolution or self.frame != other.frame:
            raise TerrainError(f"grids of {self.resolution} m in {self.frame!r} and {other.resolution} m in {other.frame!r} "
                               "do not share a lattice")
        dj = (self.origin_x - other.origin_x) / self.resolution
        di = (self.origin_y - other.origin_y) / self.resolution
        if abs(dj - round(dj)) > 1e-6 or abs(di - round(di)) > 1e-6:
            raise TerrainError("the grids' origins are not a whole number of cells apart")
        return int(round(di)), int(round(dj))

    def take(self, grid: ElevationGrid) -> ElevationGrid:
        """Return `grid` moved into this geometry cell for cell (cells it does not cover are unknown)."""
        out = self.unknown()
        di, dj = self.offset_in(GridSpec.of(grid))
        gy, gx = grid.shape
        i0, i1 = max(0, -di), min(self.ny, gy - di)
        j0, j1 = max(0, -dj), min(self.nx, gx - dj)
        if i1 > i0 and j1 > j0:
            out.z[i0:i1, j0:j1] = grid.z[i0 + di:i1 + di, j0 + dj:j1 + dj]
            out.sigma[i0:i1, j0:j1] = grid.sigma[i0 + di:i1 + di, j0 + dj:j1 + dj]
        return out
