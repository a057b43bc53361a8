"""Cross-country terrain navigation (EDDIE): the laser's terrain map, a plan across it, paths to the controller."""

from eddie.terrain.cross_country_path import CrossCountryPathConfig, TerrainPath, terrain_path

__all__ = ["CrossCountryPathConfig", "TerrainPath", "terrain_path"]
