"""The root of every error the composition root and its tools (launcher, supervisor, reports) raise."""

from __future__ import annotations

__all__ = ["SidewalkError"]


class SidewalkError(Exception):
    """Base of every error the `sidewalk` package raises."""
