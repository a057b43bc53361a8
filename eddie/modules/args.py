"""Command-line pieces every EDDIE module process shares."""

from __future__ import annotations

import argparse

from eddie.navigator.__main__ import parse_pose as _parse_pose

__all__ = ["parse_pose"]


def parse_pose(parser: argparse.ArgumentParser, text: str, flag: str = "--start-pose") -> tuple[float, float, float]:
    """Return X,Y,YAW ([m], [m], [rad]) parsed from `text`, or exit through `parser.error` naming the flag."""
    try:
        return _parse_pose(text)
    except ValueError as exc:
        parser.error(f"{flag}: {exc}")
        raise  # parser.error exits
