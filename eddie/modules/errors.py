"""Errors of EDDIE's perception/behaviour modules: one root, `EddieModuleError`."""

from __future__ import annotations

from eddie.errors import EddieError

__all__ = ["EddieModuleError", "NoRoadPath"]


class EddieModuleError(EddieError):
    """Root of every error raised by `eddie.modules`."""


class NoRoadPath(EddieModuleError):
    """Vision road following found no path: no road seen, or the route leaves the road region."""
