"""The root of every error the terrain libraries (elevation maps, pyramid, locus, matching, planner) raise."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["TerrainError"]


class TerrainError(ModuleError):
    """Base of every error the terrain libraries raise (a grid of the wrong shape, a query outside the map)."""
