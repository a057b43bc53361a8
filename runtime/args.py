"""Logging set-up shared by the module entry points (the Zenoh flags come from `wire.flags`)."""

from __future__ import annotations

import logging
import os

__all__ = ["setup_logging"]


def setup_logging() -> None:
    """Configure logging from SIDEWALK_LOG (default WARNING) on stderr."""
    logging.basicConfig(
        level=os.environ.get("SIDEWALK_LOG", "WARNING").upper(),
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )
