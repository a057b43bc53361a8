"""The root of every error the module runtime raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["ModuleRuntimeError"]


class ModuleRuntimeError(ModuleError):
    """Base of every error the module runtime (sim clock, heartbeats) raises."""
