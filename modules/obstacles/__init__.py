"""The OBSTACLE DETECTOR: the laser checked along the local path plan; posts `obstacle_report` tokens."""

from modules.obstacles.detector import ObstacleDetector, ObstacleDetectorConfig
from modules.obstacles.errors import ObstacleDetectorError

__all__ = ["ObstacleDetector", "ObstacleDetectorConfig", "ObstacleDetectorError"]
