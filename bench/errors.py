"""What a benchmark raises when it cannot measure: a process it needs did not start or answer, or what it drives did not happen."""

from __future__ import annotations

__all__ = ["BenchError"]


class BenchError(Exception):
    """A benchmark could not measure; the message says which part failed and what was tried."""
