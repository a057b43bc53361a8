"""Command-line pieces every EDDIE module process shares."""

from __future__ import annotations

import argparse
import math

__all__ = ["parse_pose"]


def parse_pose(parser: argparse.ArgumentParser, text: str, flag: str = "--start-pose") -> tuple[float, float, float]:
    """Return X,Y,YAW ([m], [m], [rad]) parsed from `text`, or exit through `parser.error` naming the flag."""
    try:
        x, y, yaw = (float(v) for v in text.split(","))
    except ValueError:
        parser.error(f"{flag}: {text!r} is not X,Y,YAW")
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        parser.error(f"{flag}: values must be finite")
    return x, y, yaw
