"""The comparison's root error."""

from __future__ import annotations

from sidewalk.errors import SidewalkError

__all__ = ["CompareError", "ClusterError"]


class CompareError(SidewalkError, ValueError):
    """A comparison that cannot be set up or read (bad flag, missing report); names what and where."""


class ClusterError(CompareError):
    """A `--cluster` that cannot run the grid (scheduler out of reach, no workers, a worker without `sidewalk`)."""
