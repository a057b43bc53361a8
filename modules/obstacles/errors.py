"""The root of every error the OBSTACLE DETECTOR raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["ObstacleDetectorError"]


class ObstacleDetectorError(ModuleError):
    """Base of every error the OBSTACLE DETECTOR raises."""
