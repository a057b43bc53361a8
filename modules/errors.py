"""The root of every error the Sidewalk modules raise; each module's own root derives from it."""

from __future__ import annotations

__all__ = ["ModuleError"]


class ModuleError(Exception):
    """Base of every error a Sidewalk module (CAPTAIN, MAP NAVIGATOR, PILOT, HELM, PERCEPTION, runtime) raises."""
