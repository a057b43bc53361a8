"""Run the mission service: `python -m eddie.mission_service --map FILE --vehicle V --start-pose X,Y,YAW [--perception on|off]`."""

from __future__ import annotations

import argparse
import math
import sys

from eddie.mission_service.mission_service import MissionService
from eddie.modules.args import parse_pose
from eddie.toolkit.module import Module, endpoint
from modules.map_navigator import load_map
from modules.pilot import pilot_config_for
from runtime.args import setup_logging
from runtime import run_module
from wire.flags import add_network_args, network_from_args

__all__ = ["main", "build_parser"]

_DESCRIPTION = "EDDIE's mission service: takes missions on the CAPTAIN's keys, keeps their status, and (without vision) drives the route"


def build_parser() -> argparse.ArgumentParser:
    """Return the mission service's argument parser (network flags included)."""
    p = argparse.ArgumentParser(prog="python -m eddie.mission_service", description=_DESCRIPTION)
    p.add_argument("--map", required=True, help="the robot's map file (routes are planned on it)")
    p.add_argument("--vehicle", choices=["navlab", "terregator"], default="terregator")
    p.add_argument("--start-pose", required=True, help="X,Y,YAW: world←local until the navigator says [m, m, rad]")
    p.add_argument("--perception", choices=["on", "off"], default="on", help="off: drive the route by dead reckoning")
    p.add_argument("--speed", type=float, default=None,
                   help="route speed without a step's limit [m/s] (default: the vehicle's top speed, as the PILOT's)")
    p.add_argument("--annotated-map", default=None, help="the run's annotated map (for the record; the map manager loads it)")
    add_network_args(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the mission service until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging()
    net = network_from_args(parser, args)
    x, y, yaw = parse_pose(parser, args.start_pose)
    if args.speed is None:
        args.speed = pilot_config_for(args.vehicle).max_speed
    if not (args.speed > 0 and math.isfinite(args.speed)):
        parser.error("--speed: must be > 0 [m/s]")
    try:
        map_data = load_map(args.map)
    except (FileNotFoundError, ValueError) as exc:
        parser.error(f"--map: {exc}")

    async def body(m: Module) -> None:
        await MissionService(m, map_data, vehicle=args.vehicle, perception=args.perception == "on",
                             world_from_local=(x, y, yaw), speed_mps=args.speed).run()

    return run_module("mission_service", endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
