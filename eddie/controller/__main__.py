"""Run the integrated controller: `python -m eddie.controller --vehicle terregator|navlab [--control-hz N] [Zenoh flags]`."""

from __future__ import annotations

import argparse
import math
import sys

from modules.helm.tracker import tracker_config_for
from runtime import add_vehicle, module_parser, parse_module_args, run_module

from eddie.controller.controller_module import ControllerModule
from eddie.controller.integrated_controller import ARC_OVERSHOOT_RAD, ControllerConfig
from eddie.toolkit.module import Module, endpoint

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the controller's argument parser (network flags included)."""
    p = module_parser("eddie.controller", __doc__)
    add_vehicle(p, default="navlab", help="vehicle model (tracker limits)")
    p.add_argument("--control-hz", type=float, default=10.0, help="drive commands and state per sim second [Hz] (≥ 10)")
    p.add_argument("--nudge-tau", type=float, default=1.0, help="nudge decay time constant [s] sim")
    p.add_argument("--max-speed", type=float, default=None,
                   help="top speed [m/s] below the vehicle's (sidewalk run --max-speed; default: the vehicle's)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the controller until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    if args.control_hz < 10.0:
        parser.error("--control-hz: must be ≥ 10 [Hz]")
    if args.nudge_tau <= 0.0:
        parser.error("--nudge-tau: must be > 0 [s]")
    if args.max_speed is not None and not (math.isfinite(args.max_speed) and args.max_speed > 0.0):
        parser.error("--max-speed: must be > 0 [m/s]")
    tracker = tracker_config_for(args.vehicle).model_copy(update={"overshoot": ARC_OVERSHOOT_RAD})
    if args.max_speed is not None:
        tracker = tracker.model_copy(update={"max_speed": min(tracker.max_speed, args.max_speed)})
    cfg = ControllerConfig(tracker=tracker, control_hz=args.control_hz, nudge_tau_s=args.nudge_tau)

    async def body(m: Module) -> None:
        await ControllerModule(m, cfg).run()

    return run_module(args.name, endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
