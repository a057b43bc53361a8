"""Run the navigator: `python -m eddie.navigator --start-pose X,Y,YAW [--deliver world_from_local=push|request …] [Zenoh flags]`."""

from __future__ import annotations

import argparse
import math
import sys

from runtime.args import setup_logging
from runtime import run_module
from wire.flags import add_network_args, network_from_args

from eddie.navigator.navigator import Navigator
from eddie.navigator.navigator_module import DELIVERY_MODES, NavigatorModule
from eddie.toolkit.module import Module, endpoint

__all__ = ["main", "build_parser", "parse_pose"]


def parse_pose(text: str) -> tuple[float, float, float]:
    """Return (x [m], y [m], yaw [rad]) of `X,Y,YAW`; raise ValueError naming what is wrong."""
    parts = text.split(",")
    if len(parts) != 3:
        raise ValueError(f"{text!r}: expected X,Y,YAW")
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise ValueError(f"{text!r}: X, Y and YAW must be numbers") from None
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"{text!r}: X, Y and YAW must be finite")
    return vals  # type: ignore[return-value]


def build_parser() -> argparse.ArgumentParser:
    """Return the navigator's argument parser (network flags included)."""
    p = argparse.ArgumentParser(prog="python -m eddie.navigator", description=__doc__)
    p.add_argument("--start-pose", default="0,0,0", help="world pose X,Y,YAW [m, m, rad] of the vehicle at the start")
    p.add_argument("--start-sigma", type=float, default=1.0, help="start position uncertainty [m] (1 σ)")
    p.add_argument("--start-sigma-yaw", type=float, default=math.radians(5.0), help="start heading uncertainty [rad] (1 σ)")
    p.add_argument("--deliver", action="append", default=None, metavar="world_from_local=MODE",
                   help="how subscribers get world←local: push (stream) or request (service); repeatable (default: both)")
    p.add_argument("--controller", default="controller", help="the controller module's name")
    p.add_argument("--name", default="navigator", help="module name")
    add_network_args(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the navigator until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging()
    net = network_from_args(parser, args)
    try:
        start = parse_pose(args.start_pose)
    except ValueError as exc:
        parser.error(f"--start-pose: {exc}")
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
