"""Run the navigator: `python -m eddie.navigator --start-pose X,Y,YAW [--deliver world_from_local=push|request …] [Zenoh flags]`."""

from __future__ import annotations

import argparse
import math
import sys

from runtime import add_start_pose, module_parser, parse_module_args, run_module

from eddie.navigator.navigator import Navigator
from eddie.navigator.navigator_module import DELIVERY_MODES, NavigatorModule
from eddie.toolkit.module import Module, endpoint

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the navigator's argument parser (network flags included)."""
    p = module_parser("eddie.navigator", __doc__)
    add_start_pose(p, help="world pose X,Y,YAW [m, m, rad] of the vehicle at the start")
    p.add_argument("--start-sigma", type=float, default=1.0, help="start position uncertainty [m] (1 σ)")
    p.add_argument("--start-sigma-yaw", type=float, default=math.radians(5.0), help="start heading uncertainty [rad] (1 σ)")
    p.add_argument("--deliver", action="append", default=None, metavar="world_from_local=MODE",
                   help="how subscribers get world←local: push (stream) or request (service); repeatable (default: both)")
    p.add_argument("--controller", default="controller", help="the controller module's name")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the navigator until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    start = args.start_pose
    modes: set[str] = set()
    for d in args.deliver or [f"world_from_local={m}" for m in DELIVERY_MODES]:
        stream, _, mode = d.partition("=")
        if stream != "world_from_local" or mode not in DELIVERY_MODES:
            parser.error(f"--deliver: {d!r}: expected world_from_local=push or world_from_local=request")
        modes.add(mode)
    if args.start_sigma <= 0 or args.start_sigma_yaw <= 0:
        parser.error("--start-sigma/--start-sigma-yaw: must be > 0")
    nav = Navigator(start, sigma_xy=args.start_sigma, sigma_yaw=args.start_sigma_yaw)

    async def body(m: Module) -> None:
        await NavigatorModule(m, nav, deliver=frozenset(modes), controller=args.controller).run()

    return run_module(args.name, endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
