"""The OBSTACLE DETECTOR: the laser checked along the local path plan; posts `obstacle_report` tokens; `python -m codger.obstacles`."""

from codger.obstacles.detector import ObstacleDetector, ObstacleDetectorConfig

__all__ = ["ObstacleDetector", "ObstacleDetectorConfig"]
