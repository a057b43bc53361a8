"""Run the PILOT module: `python -m codger.pilot [--vehicle navlab|terregator] [--perception auto|on|off] …`."""

from __future__ import annotations

import argparse
import sys

from modules.pilot.config import pilot_config_for
from codger.pilot.pilot import Pilot
from runtime import add_network_args, network_from_args, run_module, setup_logging
from codger.blackboard_part import BlackboardPart

__all__ = ["main", "build_parser"]


def _pose(text: str) -> tuple[float, float, float]:
    try:
        x, y, yaw = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--start-pose wants X,Y,YAW (metres, metres, radians), got {text!r}") from None
    return (x, y, yaw)


def build_parser() -> argparse.ArgumentParser:
    """Return the PILOT's argument parser (network flags included)."""
    p = argparse.ArgumentParser(prog="python -m codger.pilot", description=__doc__)
    p.add_argument("--vehicle", choices=["navlab", "terregator"], default="navlab", help="vehicle model (planner, margins, speed)")
    p.add_argument("--perception", choices=["auto", "on", "off"], default="auto",
                   help="on: wait for PERCEPTION; off: dead reckoning on the map; auto: on, falling back to off when unanswered")
    p.add_argument("--perception-timeout", type=float, default=None, help="sim seconds to wait for a driving unit result [s]")
    p.add_argument("--start-pose", type=_pose, default=None, help="world←vehicle at odometry zero: X,Y,YAW [m,m,rad]")
    p.add_argument("--max-speed", type=float, default=None, help="speed when a segment sets no limit [m/s]")
    p.add_argument("--seed", type=int, default=0, help="seed of the planner's sampling")
    p.add_argument("--name", default="pilot", help="module name (liveliness, heartbeat)")
    add_network_args(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the PILOT until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging()
    net = network_from_args(parser, args)
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
