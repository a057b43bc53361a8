"""The command-line flags of FIDO as an obstacle sensor, shared by CODGER's detector and EDDIE's obstacle stop."""

from __future__ import annotations

import argparse

from pydantic import ValidationError

from modules.fido.obstacle_watch import FidoWatchConfig
from runtime.flags import config_flag_errors

__all__ = ["add_watch_args", "watch_config"]

#: the watch's settings that have a flag (each flag is the field's name with dashes)
_FIELDS = ("stereo_size", "min_features", "min_age")


def add_watch_args(p: argparse.ArgumentParser) -> None:
    """Add `--stereo-size`, `--min-features` and `--min-age` to `p`."""
    d = FidoWatchConfig()
    p.add_argument("--stereo-size", type=int, default=d.stereo_size, help="the stereo images' side [px] (a multiple of 64)")
    p.add_argument("--min-features", type=int, default=d.min_features, help="obstacle features in the corridor that make an obstacle")
    p.add_argument("--min-age", type=int, default=d.min_age,
                   help="steps an obstacle feature must have been tracked before it counts (0: its first sighting)")


def watch_config(parser: argparse.ArgumentParser, args: argparse.Namespace) -> FidoWatchConfig:
    """Return the watch's settings from the parsed flags (a bad one exits through `parser.error`, naming the flag)."""
    try:
        return FidoWatchConfig(**{f: getattr(args, f) for f in _FIELDS})
    except ValidationError as exc:
        parser.error(config_flag_errors(exc))
