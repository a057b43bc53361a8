"""The root of every error the module runtime raises."""

from __future__ import annotations

__all__ = ["ModuleRuntimeError"]


class ModuleRuntimeError(Exception):
    """Base of every error the module runtime (sim clock, heartbeats) raises."""
