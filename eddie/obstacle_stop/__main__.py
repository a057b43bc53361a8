"""Run obstacle stop: `python -m eddie.obstacle_stop --vehicle V [--asleep]`."""

from __future__ import annotations

import argparse
import sys

from eddie.modules.args import parse_pose
from eddie.obstacle_stop.obstacle_stop import ObstacleStopConfig
from eddie.obstacle_stop.obstacle_stop_module import BODY_FRONT_M, ObstacleStop, corridor_half_width
from eddie.toolkit.module import Module, endpoint
from modules.helm.tracker import tracker_config_for
from runtime.args import setup_logging
from runtime import run_module
from wire.flags import add_network_args, network_from_args

__all__ = ["main", "build_parser"]

_DESCRIPTION = 'Obstacle stop as an EDDIE process: stops the controller when something stands on its path'


def build_parser() -> argparse.ArgumentParser:
    """Return the module's argument parser (network flags included)."""
    p = argparse.ArgumentParser(prog="python -m eddie.obstacle_stop", description=_DESCRIPTION)
    p.add_argument("--vehicle", choices=["navlab", "terregator"], default="terregator")
    p.add_argument("--map", default=None, help="(accepted for a uniform command line; not used)")
    p.add_argument("--start-pose", default="0,0,0", help="X,Y,YAW: world←local until the navigator says [m, m, rad] (for stop at object)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--stop-distance", type=float, default=ObstacleStopConfig().stop_distance_m, help="stop for an obstacle this near along the path [m]")
    p.add_argument("--half-width", type=float, default=None,
                   help="half the corridor swept along the path [m] (default: the PILOT's obstacle clearance for the vehicle)")
    p.add_argument("--asleep", action="store_true", help="start asleep (a trigger wakes it)")
    add_network_args(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run obstacle stop until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging()
    net = network_from_args(parser, args)
    if not args.stop_distance > 0:
        parser.error("--stop-distance: must be > 0 [m]")
    half = corridor_half_width(args.vehicle) if args.half_width is None else args.half_width
    if not half > 0:
        parser.error("--half-width: must be > 0 [m]")
    cfg = ObstacleStopConfig(stop_distance_m=args.stop_distance, half_width_m=half, front_m=BODY_FRONT_M[args.vehicle],
                             decel_mps2=tracker_config_for(args.vehicle).max_decel)
    start = parse_pose(parser, args.start_pose)

    async def body(m: Module) -> None:
        await ObstacleStop(m, awake=not args.asleep, cfg=cfg, start=start).run()

    return run_module("obstacle_stop", endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
