"""The root of every error the CAPTAIN raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["CaptainError"]


class CaptainError(ModuleError):
    """Base of every error the CAPTAIN (mission files, requests, sequencing, submission) raises."""
