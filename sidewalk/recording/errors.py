"""The recording package's root error."""

from __future__ import annotations

__all__ = ["RecordingError"]


class RecordingError(Exception):
    """A recording that cannot be written or read (the message names the file and what is wrong)."""
