"""Run the OBSTACLE DETECTOR: `python -m codger.obstacles [--period S] [--half-width M] …`."""

from __future__ import annotations

import argparse
import sys

from pydantic import ValidationError

from codger.obstacles.detector import ObstacleDetector, ObstacleDetectorConfig
from runtime import module_parser, parse_module_args, run_module
from codger.blackboard_part import BlackboardPart

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the OBSTACLE DETECTOR's argument parser (network flags included)."""
    p = module_parser("codger.obstacles", __doc__)
    p.add_argument("--period", type=float, default=0.1, help="seconds of sim time between scans [s]")
    p.add_argument("--half-width", type=float, default=1.5, help="half-width of the corridor along the plan [m]")
    p.add_argument("--lookahead", type=float, default=20.0, help="how far along the plan to check [m]")
    p.add_argument("--map", default=None, help="the robot's map file: its landmarks give position fixes (landmark_fix)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the OBSTACLE DETECTOR until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    try:
        cfg = ObstacleDetectorConfig(period_s=args.period, half_width=args.half_width, lookahead_m=args.lookahead)
    except ValidationError as exc:
        parser.error("; ".join(f"--{str(e['loc'][0]).replace('_', '-')}: {e['msg']}" for e in exc.errors()))

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
