"""The terrain map a cross-country module keeps (Navlab 1990 §2.3.3–2.3.5): ERIM images fused into one world map, its pyramid, its tiles.

Both architectures' terrain modules hold one: each ERIM image becomes a locus map around the
vehicle (registered in x, y, roll, pitch, yaw by the pose estimate), is registered in z by the mean
difference over the cells the map already knows, fused cell by cell, and the terrain pyramid is
rebuilt over the changed block only. The map is cut into square tiles on the world lattice for the
`terrain_tile` tokens (`tiles`), and a map can be rebuilt from tiles (`paste`) by a reader that
plans on them (the PILOT). Frames: `world`; the grid's cells on the lattice through the origin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import TerrainError
from modules.terrain.fusion import fuse
from modules.terrain.grid_spec import GridSpec
from modules.terrain.inadmissible_cells import inadmissible_cells
from modules.terrain.locus import LocusParams, locus_map
from modules.terrain.pyramid import TerrainPyramid
from modules.terrain.range_image import RangeImage
from modules.terrain.vehicle_model import TerrainVehicle
from modules.terrain.vehicle_pose import VehiclePose
from modules.terrain.wheel_footprint import FOOTPRINT_MARGIN_M, footprint_heights
from modules.vocabulary.terrain import TerrainTile

__all__ = ["TerrainMap", "TileIndex"]


@dataclass(frozen=True, order=True)
class TileIndex:
    """A tile of the map: row `ti`, column `tj` of tiles of `tile_cells` × `tile_cells` cells from the map's cell (0, 0)."""

    ti: int
    tj: int


class TerrainMap:
    """A world-frame elevation map over `bounds` (x0, y0, x1, y1) [m] at `resolution` [m], with its pyramid."""

    def __init__(self, bounds: tuple[float, float, float, float], resolution: float, vehicle: TerrainVehicle, *,
                 tile_cells: int = 64, locus: LocusParams = LocusParams()) -> None:
        """Start a map of `bounds` with no cell known; tiles are `tile_cells` cells square."""
        x0, y0, x1, y1 = bounds
        if not (x1 > x0 and y1 > y0 and resolution > 0.0 and tile_cells >= 1):
            raise TerrainError(f"a terrain map needs x1 > x0, y1 > y0, resolution > 0 and tiles ≥ 1 cell, got {bounds}, "
                               f"{resolution} m, {tile_cells} cells")
        j0, i0 = math.floor(x0 / resolution), math.floor(y0 / resolution)
        j1, i1 = math.ceil(x1 / resolution), math.ceil(y1 / resolution)
        self.spec = GridSpec(j0 * resolution, i0 * resolution, resolution, i1 - i0, j1 - j0)
        self.row0, self.col0 = i0, j0  # the map's cell (0, 0) on the world lattice
        self.grid = self.spec.unknown()
        self.pyramid = TerrainPyramid(self.grid)
        self.vehicle = vehicle
        self.tile_cells = tile_cells
        self.locus = locus
        self.images = 0

    def height_near(self, x: float, y: float, reach: int = 2) -> float | None:
        """Return the mean known height [m] of the cells within `reach` cells of (x, y) [m], or None when none is known."""
        i, j = self.grid.cell_of(x, y)
        block = self.grid.z[max(i - reach, 0):i + reach + 1, max(j - reach, 0):j + reach + 1]
        return float(np.nanmean(block)) if np.isfinite(block).any() else None

    def add_image(self, image: RangeImage, pose: VehiclePose) -> tuple[list[TileIndex], float]:
        """Fuse the locus map of `image`, taken at `pose`, into the map; return the tiles it changed and the z offset applied [m]."""
        reach = self.locus.max_range + 1.0
        window = GridSpec.around(pose.x, pose.y, pose.yaw, ahead=reach, behind=1.0, side=reach,
                                 resolution=self.spec.resolution)
        grid = locus_map(image, pose.world_from_vehicle(), window, self.locus)
        di, dj = window.offset_in(self.spec)
        i0, j0 = max(di, 0), max(dj, 0)
        i1, j1 = min(di + window.ny, self.spec.ny), min(dj + window.nx, self.spec.nx)
        if i1 <= i0 or j1 <= j0:
            return [], 0.0
        part = GridSpec(self.spec.origin_x + j0 * self.spec.resolution, self.spec.origin_y + i0 * self.spec.resolution,
                        self.spec.resolution, i1 - i0, j1 - j0)
        old = ElevationGrid(part.origin_x, part.origin_y, part.resolution, self.grid.z[i0:i1, j0:j1].copy(),
                            self.grid.sigma[i0:i1, j0:j1].copy())
        merged, off = fuse(old, part.take(grid), register_z=self.images > 0)
        self.grid.z[i0:i1, j0:j1] = merged.z
        self.grid.sigma[i0:i1, j0:j1] = merged.sigma
        self.pyramid.update(self.grid, i0, i1, j0, j1)
        self.images += 1
        return self._tiles_around(i0, i1, j0, j1), off.dz

    def add_footprint(self, pose: VehiclePose, ahead: float = 0.0, margin: float = FOOTPRINT_MARGIN_M) -> list[TileIndex]:
        """Write the vehicle's own plane at `pose` into the unknown cells under it (and `ahead` [m] of it); return the tiles changed.

        See `modules.terrain.wheel_footprint`: the ground the wheels stand on, which the laser never sees.
        """
        block = footprint_heights(self.grid, pose, self.vehicle, ahead=ahead, margin=margin)
        if block is None:
            return []
        i0, i1, j0, j1 = block
        self.pyramid.update(self.grid, i0, i1, j0, j1)
        return self._tiles_around(i0, i1, j0, j1)

    def _tiles_around(self, i0: int, i1: int, j0: int, j1: int) -> list[TileIndex]:
        """Return the tiles of the block (i0:i1, j0:j1) and the ring of cells around it (the pyramid's slope and discontinuity there changed too)."""
        t = self.tile_cells
        r0, r1, c0, c1 = max(i0 - 1, 0), min(i1 + 1, self.spec.ny), max(j0 - 1, 0), min(j1 + 1, self.spec.nx)
        return [TileIndex(ti, tj) for ti in range(r0 // t, (r1 - 1) // t + 1) for tj in range(c0 // t, (c1 - 1) // t + 1)]

    def tiles(self, which: list[TileIndex], sensed_at: float) -> list[TerrainTile]:
        """Return the `terrain_tile` tokens of tiles `which`: heights, sigmas and inadmissible cells."""
        out = []
        t = self.tile_cells
        for idx in which:
            rows = slice(idx.ti * t, min((idx.ti + 1) * t, self.spec.ny))
            cols = slice(idx.tj * t, min((idx.tj + 1) * t, self.spec.nx))
            out.append(TerrainTile.encode(self.row0 + rows.start, self.col0 + cols.start, self.spec.resolution,
                                          self.grid.z[rows, cols], self.grid.sigma[rows, cols],
                                          inadmissible_cells(self.pyramid, self.vehicle, rows, cols), sensed_at))
        return out

    def paste(self, tile: TerrainTile) -> bool:
        """Write `tile` into the map and update the pyramid under it; False when it lies outside the map or off its lattice."""
        if abs(tile.resolution - self.spec.resolution) > 1e-9:
            return False
        i0, j0 = tile.row0 - self.row0, tile.col0 - self.col0
        r0, r1 = max(i0, 0), min(i0 + tile.ny, self.spec.ny)
        c0, c1 = max(j0, 0), min(j0 + tile.nx, self.spec.nx)
        if r1 <= r0 or c1 <= c0:
            return False
        z, s = tile.heights()
        self.grid.z[r0:r1, c0:c1] = z[r0 - i0:r1 - i0, c0 - j0:c1 - j0]
        self.grid.sigma[r0:r1, c0:c1] = s[r0 - i0:r1 - i0, c0 - j0:c1 - j0]
        self.pyramid.update(self.grid, r0, r1, c0, c1)
        return True
