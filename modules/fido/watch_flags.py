"""The command-line flags of FIDO as an obstacle sensor, shared by CODGER's detector and EDDIE's obstacle stop."""

from __future__ import annotations

import argparse

from modules.fido.obstacle_watch import FidoWatchConfig

__all__ = ["add_watch_args", "watch_values"]

#: the watch's settings that have a flag (each flag is the field's name with dashes)
_FIELDS = ("stereo_size", "min_features", "min_age")


def add_watch_args(p: argparse.ArgumentParser) -> None:
    """Add `--stereo-size`, `--min-features` and `--min-age` to `p`."""
    d = FidoWatchConfig()
    p.add_argument("--stereo-size", type=int, default=d.stereo_size, help="the stereo images' side [px] (a multiple of 64)")
    p.add_argument("--min-features", type=int, default=d.min_features, help="obstacle features in the corridor that make an obstacle")
    p.add_argument("--min-age", type=int, default=d.min_age,
                   help="steps an obstacle feature must have been tracked before it counts (0: its first sighting)")


def watch_values(args: argparse.Namespace) -> dict[str, object]:
    """Return the watch's settings given by the parsed flags, by field (build them with `runtime.flags.config_from_flags`)."""
    return {f: getattr(args, f) for f in _FIELDS}
