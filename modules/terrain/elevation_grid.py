"""An elevation grid: heights [m] on a regular x-y grid in one named frame, with a standard deviation per cell.

The contract between the elevation maps (buckets, the locus method), the terrain pyramid and the
cross-country planner (Navlab 1990 §2.3.3–2.4). A cell is *unknown* (never seen, or in a range
shadow) when its height is NaN; its sigma is then +inf. Cell (row i, column j) covers
x ∈ [origin_x + j·resolution, origin_x + (j+1)·resolution), y ∈ [origin_y + i·resolution, …).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modules.terrain.errors import TerrainError

__all__ = ["ElevationGrid"]


@dataclass(frozen=True)
class ElevationGrid:
    """Heights z [m] and their standard deviations sigma [m] on a grid of `resolution` [m] in `frame`.

    `z` and `sigma` are float32 arrays of shape (ny, nx); NaN in `z` (and inf in `sigma`) marks an
    unknown cell. `origin_x`, `origin_y` [m] are the lower-left corner of cell (0, 0) in `frame`.
    """

    origin_x: float
    origin_y: float
    resolution: float
    z: np.ndarray
    sigma: np.ndarray
    frame: str = "world"

    def __post_init__(self) -> None:
        if not self.resolution > 0.0:
            raise TerrainError(f"an elevation grid's resolution must be > 0 m, not {self.resolution}")
        if self.z.ndim != 2 or self.z.shape != self.sigma.shape:
            raise TerrainError(f"z {self.z.shape} and sigma {self.sigma.shape} must be equal 2-D shapes (ny, nx)")

    @property
    def shape(self) -> tuple[int, int]:
        """Return (ny, nx), the grid's rows and columns."""
        return (int(self.z.shape[0]), int(self.z.shape[1]))

    @property
    def known(self) -> np.ndarray:
        """Return the (ny, nx) bool mask of cells with a height."""
        return ~np.isnan(self.z)

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """Return (row, column) of the cell holding point (x, y) [m] in `frame` (may lie outside the grid)."""
        return (int(np.floor((y - self.origin_y) / self.resolution)),
                int(np.floor((x - self.origin_x) / self.resolution)))

    def centre_of(self, row: int, col: int) -> tuple[float, float]:
        """Return the centre (x, y) [m] in `frame` of cell (row, col)."""
        return (self.origin_x + (col + 0.5) * self.resolution, self.origin_y + (row + 0.5) * self.resolution)

    @classmethod
    def unknown(cls, origin_x: float, origin_y: float, resolution: float, ny: int, nx: int,
                frame: str = "world") -> "ElevationGrid":
        """Return a grid of (ny, nx) cells none of which is known yet."""
        return cls(origin_x, origin_y, resolution, np.full((ny, nx), np.nan, np.float32),
                   np.full((ny, nx), np.inf, np.float32), frame)
