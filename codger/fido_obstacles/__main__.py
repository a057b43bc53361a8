"""Run the FIDO OBSTACLE DETECTOR: `python -m codger.fido_obstacles [--period S] [--half-width M] [--stereo-size PX] …`."""

from __future__ import annotations

import argparse
import sys

from codger.blackboard_part import BlackboardPart
from codger.fido_obstacles.detector import FidoObstacleDetector
from codger.obstacles.__main__ import add_corridor_args, detector_config
from modules.fido.obstacle_watch import FidoWatchConfig
from modules.fido.watch_flags import add_watch_args, watch_values
from runtime import module_parser, parse_module_args, run_module
from runtime.flags import config_from_flags

__all__ = ["main", "build_parser"]

#: FIDO's step period [s] sim: the ERIM's 2 frames/s, so both sensors look as often
FIDO_PERIOD_S = 0.5


def build_parser() -> argparse.ArgumentParser:
    """Return the FIDO OBSTACLE DETECTOR's argument parser (network flags included)."""
    p = module_parser("codger.fido_obstacles", __doc__)
    add_corridor_args(p, period_s=FIDO_PERIOD_S, frames="stereo pairs")
    add_watch_args(p)
    p.add_argument("--map", default=None, help="(accepted for a uniform command line; FIDO gives no landmark fixes)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the FIDO OBSTACLE DETECTOR until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    cfg = detector_config(parser, args)
    watch = config_from_flags(parser, FidoWatchConfig, watch_values(args))

    async def body(rt) -> None:
        await FidoObstacleDetector(rt, cfg, watch).run()

    return run_module(args.name, body, net, parts=(BlackboardPart(),))


if __name__ == "__main__":
    sys.exit(main())
