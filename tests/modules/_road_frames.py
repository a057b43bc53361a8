"""One renderer per world for the road-following tests (building a scene takes seconds; the frames are pure)."""

from __future__ import annotations

from functools import lru_cache

from sidewalk.cli._roadfollow import RouteFrames

__all__ = ["route_frames"]


@lru_cache(maxsize=2)
def route_frames(world: str) -> RouteFrames:
    """Return the (shared) frame source of `world`'s mission legs."""
    return RouteFrames(world)
