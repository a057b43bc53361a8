"""The root of every error the PILOT raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["PilotError"]


class PilotError(ModuleError):
    """Base of every error the PILOT (paths, estimation, constraints, planning) raises."""
