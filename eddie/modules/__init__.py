"""EDDIE's perception/behaviour modules: vision road following, landmark matching, obstacle stop.

Each is a process woken or switched by the annotated map's triggers; the cores here are plain
functions over PERCEPTION's and the PILOT's libraries, so EDDIE and CODGER run the same algorithms.
"""

from eddie.modules.errors import EddieModuleError, NoRoadPath
from eddie.modules.landmark_matching import LandmarkFix, landmark_fix
from eddie.modules.obstacle_stop import ObstacleReport, ObstacleStopConfig, obstacle_ahead
from eddie.modules.road_following import (
    RoadFollowingConfig, RoadPath, plan_road_path, region_in_local, route_goal, route_to_local,
)

__all__ = [
    "EddieModuleError", "NoRoadPath", "LandmarkFix", "landmark_fix",
    "ObstacleReport", "ObstacleStopConfig", "obstacle_ahead",
    "RoadFollowingConfig", "RoadPath", "plan_road_path", "region_in_local", "route_goal", "route_to_local",
]
