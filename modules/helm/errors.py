"""The root of every error the HELM raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["HelmError"]


class HelmError(ModuleError):
    """Base of every error the HELM (plans it cannot track) raises."""
