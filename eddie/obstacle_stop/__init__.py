"""Obstacle stop (EDDIE): the laser along the controller's path, stop and hold; stop at the mission's object; `python -m eddie.obstacle_stop`."""

from eddie.obstacle_stop.obstacle_stop import ObstacleReport, ObstacleStopConfig, obstacle_ahead
from eddie.obstacle_stop.obstacle_stop_module import ObstacleStop

__all__ = ["ObstacleReport", "ObstacleStopConfig", "obstacle_ahead", "ObstacleStop"]
