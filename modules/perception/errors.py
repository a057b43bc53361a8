"""The root of every error PERCEPTION raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["PerceptionError"]


class PerceptionError(ModuleError):
    """Base of every error PERCEPTION (sensor frames, images, colour classes, position fixes) raises."""
