"""The recording package's root error."""

from __future__ import annotations

from sidewalk.errors import SidewalkError

__all__ = ["RecordingError"]


class RecordingError(SidewalkError):
    """A recording that cannot be written or read (the message names the file and what is wrong)."""
