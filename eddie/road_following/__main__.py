"""Run vision road following: `python -m eddie.road_following --vehicle V --map FILE --start-pose X,Y,YAW [--seed N]
[--road-method perception|scarf|yarf|alvinn] [--alvinn-weights FILE]`."""

from __future__ import annotations

import argparse
import sys

from eddie.road_following.road_following_module import RoadFollowing
from eddie.toolkit.module import Module, endpoint
from modules.map_navigator import load_map
from modules.road_following import RoadFollowingError
from modules.road_following.road_method import ROAD_METHODS, load_alvinn_weights
from runtime import add_seed, add_start_pose, add_vehicle, module_parser, parse_module_args, run_module

__all__ = ["main", "build_parser"]

_DESCRIPTION = 'Vision road following as an EDDIE process: sees the road, plans in `local`, sends paths to the controller'


def build_parser() -> argparse.ArgumentParser:
    """Return the module's argument parser (network flags included)."""
    p = module_parser("eddie.road_following", _DESCRIPTION)
    add_vehicle(p)
    p.add_argument("--map", required=True, help="the robot's map file (the objects PERCEPTION looks for)")
    add_start_pose(p, help="X,Y,YAW: world←local until the navigator says [m, m, rad]")
    add_seed(p)
    p.add_argument("--asleep", action="store_true", help="start asleep (a trigger wakes it)")
    p.add_argument("--road-method", choices=ROAD_METHODS, default="perception",
                   help="how the road is found: PERCEPTION's colored-range segmentation, or the SCARF, YARF or ALVINN follower")
    p.add_argument("--alvinn-weights", default="", help="ALVINN's weights (.npz from `sidewalk roadfollow train`); needed with --road-method alvinn")
    p.add_argument("--vision-workers", type=int, default=1,
                   help="processes the per-pixel stages of PERCEPTION's segmentation run on in stripes (1: this process alone)")
    p.add_argument("--keep", choices=["centre", "right", "left"], default="centre",
                   help="drive on the road's centre or keep right / left (a quarter of its width off the centre): the mission step's side")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run vision road following until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    start = args.start_pose
    if not 1 <= args.vision_workers <= 64:
        parser.error(f"--vision-workers: expected 1 to 64, got {args.vision_workers}")
    try:
        map_data = load_map(args.map)
    except (FileNotFoundError, ValueError) as exc:
        parser.error(f"--map: {exc}")
    alvinn_net = None
    if args.road_method == "alvinn":
        try:
            alvinn_net = load_alvinn_weights(args.alvinn_weights)
        except RoadFollowingError as exc:
            parser.error(f"--alvinn-weights: {exc}")

    async def body(m: Module) -> None:
        await RoadFollowing(m, map_data, vehicle=args.vehicle, seed=args.seed, start=start, awake=not args.asleep,
                            method=args.road_method, alvinn_net=alvinn_net, keep=args.keep,
                            vision_workers=args.vision_workers).run()

    return run_module(args.name, endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
