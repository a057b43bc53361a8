"""Inadmissible cells (Navlab 1990 §2.4, Figure 2.15): cells no wheel of the vehicle may stand on, for display and tokens.

A cell is inadmissible when its slope exceeds the gentler of the vehicle's tip-over limits or its
discontinuity exceeds the largest step the vehicle can climb. This is a per-cell picture of the
environmental constraints for the monitor and the terrain tokens; the planner itself checks whole
configurations (`constraints`, `resolution_hierarchy`), not single cells.
"""

from __future__ import annotations

import math

import numpy as np

from modules.terrain.pyramid import TerrainPyramid
from modules.terrain.vehicle_model import TerrainVehicle

__all__ = ["inadmissible_cells"]


def inadmissible_cells(pyramid: TerrainPyramid, vehicle: TerrainVehicle, rows: slice = slice(None),
                       cols: slice = slice(None)) -> np.ndarray:
    """Return the bool mask (rows, cols) of the pyramid's level-0 cells too steep or too broken for `vehicle`."""
    cells = pyramid.level(0)
    slope, disc = cells.slope[rows, cols], cells.disc[rows, cols]
    limit = math.tan(min(vehicle.max_roll, vehicle.max_pitch))
    with np.errstate(invalid="ignore"):
        return (slope > limit) | (disc > vehicle.max_step)
