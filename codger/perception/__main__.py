"""Run the PERCEPTION module: `python -m codger.perception [--vehicle navlab|terregator] [--speed M/S] …`."""

from __future__ import annotations

import argparse
import sys

from pydantic import ValidationError

from codger.perception.module import PerceptionConfig, PerceptionModule
from modules.perception.road_method import RoadMethodPerception
from modules.road_following import ROAD_METHODS, CameraRoadFollower, RoadFollowingError, load_alvinn_weights
from runtime import add_vehicle, module_parser, parse_module_args, run_module
from codger.blackboard_part import BlackboardPart

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the PERCEPTION argument parser (network flags included)."""
    p = module_parser("codger.perception", __doc__)
    add_vehicle(p, help="sensor mounting")
    p.add_argument("--speed", type=float, default=1.0, help="desired speed for the view/resolution table [m/s]")
    p.add_argument("--max-wait", type=float, default=6.0, help="longest wait for the image input position [s] sim")
    p.add_argument("--road-method", choices=ROAD_METHODS, default="perception",
                   help="what finds the road of follow-road units: the colored-range pipeline, or the SCARF, YARF or ALVINN follower")
    p.add_argument("--alvinn-weights", default="", help="ALVINN's weights (.npz from `sidewalk roadfollow train`); needed with --road-method alvinn")
    p.add_argument("--vision-workers", type=int, default=1,
                   help="processes the per-pixel stages (registration, colour classification) run on in stripes; 1: this process alone")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run PERCEPTION until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    try:
        cfg = PerceptionConfig(vehicle=args.vehicle, speed=args.speed, max_wait_s=args.max_wait, road_method=args.road_method,
                               vision_workers=args.vision_workers)
    except ValidationError as exc:
        parser.error("; ".join(f"--{e['loc'][0]}: {e['msg']}" for e in exc.errors()))
    road = None
    if args.road_method != "perception":
        try:
            alvinn = load_alvinn_weights(args.alvinn_weights) if args.road_method == "alvinn" else None
        except RoadFollowingError as exc:
            parser.error(f"--alvinn-weights: {exc}")
        road = RoadMethodPerception(CameraRoadFollower(args.road_method, alvinn_net=alvinn))

    async def body(rt) -> None:
        await PerceptionModule(rt, cfg, road=road).run()

    return run_module(args.name, body, net, parts=(BlackboardPart(),))


if __name__ == "__main__":
    sys.exit(main())
