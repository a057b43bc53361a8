"""The root of every error the road followers (SCARF, YARF, ALVINN) raise."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["RoadFollowingError", "CameraGeometryError", "AlvinnModelError"]


class RoadFollowingError(ModuleError):
    """Base of every error a road follower (camera geometry, colour classes, trackers, the net) raises."""


class CameraGeometryError(RoadFollowingError, ValueError):
    """A camera model or image a road follower cannot use; the message names the field and what is wrong."""


class AlvinnModelError(RoadFollowingError, ValueError):
    """An ALVINN weights file that cannot be used; the message names the file and what is wrong."""
