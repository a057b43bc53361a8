"""Run landmark matching: `python -m eddie.landmark_matching --vehicle V --map FILE --start-pose X,Y,YAW [--asleep]`."""

from __future__ import annotations

import argparse
import sys

from eddie.landmark_matching.landmark_matching_module import LandmarkMatching
from eddie.toolkit.module import Module, endpoint
from modules.map_navigator import load_map
from runtime import add_seed, add_start_pose, add_vehicle, module_parser, parse_module_args, run_module

__all__ = ["main", "build_parser"]

_DESCRIPTION = 'Landmark matching as an EDDIE process: position fixes from the landmarks in view, sent to the navigator'


def build_parser() -> argparse.ArgumentParser:
    """Return the module's argument parser (network flags included)."""
    p = module_parser("eddie.landmark_matching", _DESCRIPTION)
    add_vehicle(p)
    p.add_argument("--map", required=True, help="the robot's map file (the landmarks)")
    add_start_pose(p, help="X,Y,YAW: world←local until the navigator says [m, m, rad]")
    add_seed(p)
    p.add_argument("--period", type=float, default=2.0, help="one fix attempt per this much sim time [s]")
    p.add_argument("--asleep", action="store_true", help="start asleep (a trigger wakes it)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run landmark matching until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    start = args.start_pose
    if not args.period > 0:
        parser.error("--period: must be > 0 [s]")
    try:
        map_data = load_map(args.map)
    except (FileNotFoundError, ValueError) as exc:
        parser.error(f"--map: {exc}")

    async def body(m: Module) -> None:
        await LandmarkMatching(m, map_data, vehicle=args.vehicle, start=start, awake=not args.asleep, period_s=args.period).run()

    return run_module(args.name, endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
