"""The mission compiler's errors: one root, `MissionCompileError` (an `EddieError`)."""

from __future__ import annotations

from eddie.errors import EddieError

__all__ = ["MissionCompileError"]


class MissionCompileError(EddieError, ValueError):
    """A mission that cannot be compiled over its map (bad file, unknown place, no route); the message says which step."""
