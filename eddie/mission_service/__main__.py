"""Run the mission service: `python -m eddie.mission_service --map FILE --vehicle V --start-pose X,Y,YAW [--perception on|off]`."""

from __future__ import annotations

import argparse
import math
import sys

from eddie.mission_service.mission_service import MissionService
from eddie.toolkit.module import Module, endpoint
from modules.map_navigator import load_map
from modules.pilot import pilot_config_for
from runtime import add_start_pose, add_vehicle, module_parser, parse_module_args, run_module

__all__ = ["main", "build_parser"]

_DESCRIPTION = "EDDIE's mission service: takes missions on the CAPTAIN's keys, keeps their status, and (without vision) drives the route"


def build_parser() -> argparse.ArgumentParser:
    """Return the mission service's argument parser (network flags included)."""
    p = module_parser("eddie.mission_service", _DESCRIPTION)
    p.add_argument("--map", required=True, help="the robot's map file (routes are planned on it)")
    add_vehicle(p)
    add_start_pose(p, required=True, help="X,Y,YAW: world←local until the navigator says [m, m, rad]")
    p.add_argument("--perception", choices=["on", "off"], default="on", help="off: drive the route by dead reckoning")
    p.add_argument("--speed", type=float, default=None,
                   help="route speed without a step's limit [m/s] (default: the vehicle's top speed, as the PILOT's)")
    p.add_argument("--annotated-map", default=None, help="the run's annotated map (for the record; the map manager loads it)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the mission service until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    x, y, yaw = args.start_pose
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

    return run_module(args.name, endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
