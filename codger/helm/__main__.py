"""Run the HELM module: `python -m codger.helm [--vehicle navlab|terregator] [--control-hz N] …`."""

from __future__ import annotations

import argparse
import sys

from codger.helm.helm import DriveKeys, Helm, helm_config_for
from runtime import add_vehicle, module_parser, parse_module_args, run_module
from codger.blackboard_part import BlackboardPart

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the HELM's argument parser (network flags included)."""
    p = module_parser("codger.helm", __doc__)
    add_vehicle(p, default="navlab", help="vehicle model (tracker limits)")
    p.add_argument("--control-hz", type=float, default=None, help="drive commands per sim second [Hz]")
    p.add_argument("--pose-hz", type=float, default=None, help="local←vehicle poses per sim second [Hz] (≥ 10)")
    p.add_argument("--drive-key", default=None, help="drive command key under sidewalk/<ns>/ (default sim/cmd)")
    p.add_argument("--odom-key", default=None, help="odometry key under sidewalk/<ns>/ (default sim/odom)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the HELM until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    keys = DriveKeys(**{k: v for k, v in (("command", args.drive_key), ("odometry", args.odom_key)) if v})
    try:
        cfg = helm_config_for(args.vehicle, control_hz=args.control_hz, pose_hz=args.pose_hz, keys=keys)
    except ValueError as exc:
        parser.error(str(exc))

    async def body(rt) -> None:
        await Helm(rt, cfg).run()

    return run_module(args.name, body, net, parts=(BlackboardPart(),))


if __name__ == "__main__":
    sys.exit(main())
