"""The TERRAIN module (CODGER): ERIM images → the terrain map → `terrain_tile` tokens; `python -m codger.terrain`."""

from codger.terrain.terrain_module import TerrainModule, TerrainModuleConfig

__all__ = ["TerrainModule", "TerrainModuleConfig"]
