"""The FIDO OBSTACLE DETECTOR: FIDO's stereo obstacle features checked along the local path plan; posts `obstacle_report` tokens; `python -m codger.fido_obstacles`."""

from codger.fido_obstacles.detector import FidoObstacleDetector

__all__ = ["FidoObstacleDetector"]
