"""Terrain from range data (Navlab 1990 §2.3.3–2.4): elevation maps, the terrain pyramid, the locus method, map matching, and the cross-country planner.

Plain libraries (no transport, no truth) that both architectures use.
"""

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import TerrainError

__all__ = ["ElevationGrid", "TerrainError"]
