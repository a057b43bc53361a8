"""The simulator package's root error."""

from __future__ import annotations

__all__ = ["SimError"]


class SimError(Exception):
    """Base of every error the simulator package raises (the message says where and what)."""
