"""Run obstacle stop: `python -m eddie.obstacle_stop --vehicle V [--asleep]`."""

from __future__ import annotations

import argparse
import sys

from eddie.obstacle_stop.obstacle_stop import ObstacleStopConfig
from eddie.obstacle_stop.obstacle_stop_module import BODY_FRONT_M, ObstacleStop, corridor_half_width
from eddie.toolkit.module import Module, endpoint
from modules.helm.tracker import tracker_config_for
from runtime import add_seed, add_start_pose, add_vehicle, module_parser, parse_module_args, run_module

__all__ = ["main", "build_parser", "stop_config"]

_DESCRIPTION = 'Obstacle stop as an EDDIE process: stops the controller when something stands on its path'


def build_parser(module: str = "eddie.obstacle_stop", description: str = _DESCRIPTION) -> argparse.ArgumentParser:
    """Return the module's argument parser (network flags included); its `--name` is `obstacle_stop` (the triggers' address)."""
    p = module_parser(module, description, name="obstacle_stop")
    add_vehicle(p)
    p.add_argument("--map", default=None, help="(accepted for a uniform command line; not used)")
    add_start_pose(p, help="X,Y,YAW: world←local until the navigator says [m, m, rad] (for stop at object)")
    add_seed(p)
    p.add_argument("--stop-distance", type=float, default=ObstacleStopConfig().stop_distance_m, help="stop for an obstacle this near along the path [m]")
    p.add_argument("--half-width", type=float, default=None,
                   help="half the corridor swept along the path [m] (default: the PILOT's obstacle clearance for the vehicle)")
    p.add_argument("--asleep", action="store_true", help="start asleep (a trigger wakes it)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run obstacle stop until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    cfg = stop_config(parser, args)
    start = args.start_pose

    async def body(m: Module) -> None:
        await ObstacleStop(m, awake=not args.asleep, cfg=cfg, start=start).run()

    return run_module(args.name, endpoint(body), net)


def stop_config(parser: argparse.ArgumentParser, args: argparse.Namespace) -> ObstacleStopConfig:
    """Return the check's settings from the parsed flags (a bad one exits through `parser.error`)."""
    if not args.stop_distance > 0:
        parser.error("--stop-distance: must be > 0 [m]")
    half = corridor_half_width(args.vehicle) if args.half_width is None else args.half_width
    if not half > 0:
        parser.error("--half-width: must be > 0 [m]")
    return ObstacleStopConfig(stop_distance_m=args.stop_distance, half_width_m=half, front_m=BODY_FRONT_M[args.vehicle],
                              decel_mps2=tracker_config_for(args.vehicle).max_decel)


if __name__ == "__main__":
    sys.exit(main())
