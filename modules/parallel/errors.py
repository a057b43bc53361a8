"""The root of every error the parallel-vision facility raises."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["ParallelError", "StripePlanError", "WorkerError"]


class ParallelError(ModuleError):
    """Base of every error of the parallel-vision facility (a bad stripe plan, a worker that failed or died)."""


class StripePlanError(ParallelError, ValueError):
    """Arrays that cannot be cut into stripes as asked (extents that disagree, a bad axis or worker count)."""


class WorkerError(ParallelError, RuntimeError):
    """A worker process failed on its stripe (the message carries its one-line error) or is gone."""
