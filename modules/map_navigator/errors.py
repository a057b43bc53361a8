"""The root of every error the MAP NAVIGATOR raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["MapNavigatorError"]


class MapNavigatorError(ModuleError):
    """Base of every error the MAP NAVIGATOR (routes it cannot give) raises."""
