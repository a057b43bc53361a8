"""The monitor package's errors: one root."""

from __future__ import annotations

from sidewalk.errors import SidewalkError

__all__ = ["MonitorError", "PortInUseError"]


class MonitorError(SidewalkError):
    """Root of the monitor's errors (the message says what is wrong in one line)."""


class PortInUseError(MonitorError):
    """The page's HTTP port is taken (or cannot be bound) on that address."""
