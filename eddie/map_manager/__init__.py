"""EDDIE's annotated map manager (seed ch. 3): queries over the annotation database, triggers fired along the travelled line."""

from eddie.map_manager.map_manager import MapManager, TravelledCycle, world_of
from eddie.map_manager.map_manager_module import MapManagerModule

__all__ = ["MapManager", "TravelledCycle", "world_of", "MapManagerModule"]
