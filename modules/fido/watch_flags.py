"""The command-line flags of FIDO as an obstacle sensor, shared by CODGER's detector and EDDIE's obstacle stop."""

from __future__ import annotations

import argparse

from pydantic import ValidationError

from modules.fido.obstacle_watch import FidoWatchConfig

__all__ = ["add_watch_args", "watch_config"]


def add_watch_args(p: argparse.ArgumentParser) -> None:
    """Add `--stereo-size` and `--min-features` to `p`."""
    p.add_argument("--stereo-size", type=int, default=FidoWatchConfig().stereo_size, help="the stereo images' side [px] (a multiple of 64)")
    p.add_argument("--min-features", type=int, default=FidoWatchConfig().min_features,
                   help="obstacle features in the corridor that make an obstacle")


def watch_config(parser: argparse.ArgumentParser, args: argparse.Namespace) -> FidoWatchConfig:
    """Return the watch's settings from the parsed flags (a bad one exits through `parser.error`, naming the flag)."""
    try:
        return FidoWatchConfig(stereo_size=args.stereo_size, min_features=args.min_features)
    except ValidationError as exc:
        parser.error("; ".join(f"--{str(e['loc'][0]).replace('_', '-')}: {e['msg']}" for e in exc.errors()))
