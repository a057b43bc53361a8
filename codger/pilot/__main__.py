"""Run the PILOT module: `python -m codger.pilot [--vehicle navlab|terregator] [--perception auto|on|off] …`."""

from __future__ import annotations

import argparse
import sys

from modules.pilot.config import pilot_config_for
from codger.pilot.pilot import Pilot
from runtime import add_seed, add_start_pose, add_vehicle, module_parser, parse_module_args, run_module
from codger.blackboard_part import BlackboardPart

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the PILOT's argument parser (network flags included)."""
    p = module_parser("codger.pilot", __doc__)
    add_vehicle(p, default="navlab", help="vehicle model (planner, margins, speed)")
    p.add_argument("--perception", choices=["auto", "on", "off"], default="auto",
                   help="on: wait for PERCEPTION; off: dead reckoning on the map; auto: on, falling back to off when unanswered")
    p.add_argument("--perception-timeout", type=float, default=None, help="sim seconds to wait for a driving unit result [s]")
    add_start_pose(p, default=None, help="world←vehicle at odometry zero: X,Y,YAW [m,m,rad]")
    p.add_argument("--max-speed", type=float, default=None, help="speed when a segment sets no limit [m/s]")
    add_seed(p, help="seed of the planner's sampling")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the PILOT until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    try:
        cfg = pilot_config_for(args.vehicle, perception=args.perception, perception_timeout_s=args.perception_timeout,
                               start_pose=args.start_pose, max_speed=args.max_speed, seed=args.seed)
    except ValueError as exc:
        parser.error(str(exc))

    async def body(rt) -> None:
        await Pilot(rt, cfg).run()

    return run_module(args.name, body, net, parts=(BlackboardPart(),))


if __name__ == "__main__":
    sys.exit(main())
