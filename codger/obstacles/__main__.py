"""Run the OBSTACLE DETECTOR: `python -m codger.obstacles [--period S] [--half-width M] …`."""

from __future__ import annotations

import argparse
import sys

from pydantic import ValidationError

from codger.obstacles.detector import ObstacleDetector, ObstacleDetectorConfig
from runtime import config_flag_errors, module_parser, parse_module_args, run_module
from codger.blackboard_part import BlackboardPart

__all__ = ["main", "build_parser", "add_corridor_args", "detector_config"]


def build_parser() -> argparse.ArgumentParser:
    """Return the OBSTACLE DETECTOR's argument parser (network flags included)."""
    p = module_parser("codger.obstacles", __doc__)
    add_corridor_args(p, period_s=ObstacleDetectorConfig().period_s, frames="scans")
    p.add_argument("--map", default=None, help="the robot's map file: its landmarks give position fixes (landmark_fix)")
    return p


#: the config's fields → the flags that set them
_FLAGS = {"period_s": "--period", "half_width": "--half-width", "lookahead_m": "--lookahead"}


def add_corridor_args(p: argparse.ArgumentParser, *, period_s: float, frames: str) -> None:
    """Add the detector's cycle and corridor flags (`--period`, `--half-width`, `--lookahead`) to `p`."""
    p.add_argument("--period", type=float, default=period_s, help=f"seconds of sim time between {frames} [s]")
    p.add_argument("--half-width", type=float, default=ObstacleDetectorConfig().half_width, help="half-width of the corridor along the plan [m]")
    p.add_argument("--lookahead", type=float, default=ObstacleDetectorConfig().lookahead_m, help="how far along the plan to check [m]")


def detector_config(parser: argparse.ArgumentParser, args: argparse.Namespace) -> ObstacleDetectorConfig:
    """Return the detector's settings from the parsed corridor flags (a bad one exits through `parser.error`)."""
    try:
        return ObstacleDetectorConfig(period_s=args.period, half_width=args.half_width, lookahead_m=args.lookahead)
    except ValidationError as exc:
        parser.error(config_flag_errors(exc, _FLAGS))


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the OBSTACLE DETECTOR until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    cfg = detector_config(parser, args)

    landmarks = []
    if args.map:
        from modules.perception.landmarks import map_landmarks
        from wire.mapfile import WorldFileError, load_map_file

        try:
            landmarks = map_landmarks(load_map_file(args.map, kind="map").objects)
        except (FileNotFoundError, WorldFileError) as exc:
            parser.error(f"--map: {exc}")

    async def body(rt) -> None:
        await ObstacleDetector(rt, cfg, landmarks).run()

    return run_module(args.name, body, net, parts=(BlackboardPart(),))


if __name__ == "__main__":
    sys.exit(main())
