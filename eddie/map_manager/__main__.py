"""Run the map manager: `python -m eddie.map_manager [--annotated-map FILE] [--state FILE] [--controller N] [--navigator N] [Zenoh flags]`.

Without an annotated map it starts empty; each mission submitted to the mission service brings its own annotations.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from runtime import module_parser, parse_module_args, run_module

from eddie.annotated_map import AnnotatedMapError, AnnotationDatabase, load_annotations
from eddie.map_manager.map_manager import MapManager
from eddie.map_manager.map_manager_module import MapManagerModule, resume_mission
from eddie.map_manager.state_file import StateFileError, load_state
from eddie.toolkit.module import Module, endpoint

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    """Return the map manager's argument parser (network flags included)."""
    p = module_parser("eddie.map_manager", __doc__)
    p.add_argument("--annotated-map", default=None,
                   help="annotated map file (GeoJSON, `sidewalk eddie annotate`); default: none, only the submitted missions' annotations")
    p.add_argument("--controller", default="controller", help="the controller module's name (its state stream)")
    p.add_argument("--navigator", default="navigator", help="the navigator module's name (its world_from_local stream)")
    p.add_argument("--state", default=None, metavar="FILE",
                   help="keep the used flags and the vehicle's last position here, and take them up when started again "
                        "(a restart then fires the triggers crossed meanwhile; delete the file to start afresh)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags, load the annotated map and run the manager until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    try:
        db = AnnotationDatabase(() if args.annotated_map is None else load_annotations(args.annotated_map))
    except AnnotatedMapError as exc:
        parser.error(f"--annotated-map: {exc}")
    mgr = MapManager(db)
    map_name = "" if args.annotated_map is None else Path(args.annotated_map).name
    try:
        if args.state is not None:
            resume_mission(mgr, args.state)
        resume = None if args.state is None else load_state(args.state, annotated_map=map_name, known={a.id for a in db})
    except (AnnotatedMapError, StateFileError) as exc:
        parser.error(f"--state: {exc}")

    async def body(m: Module) -> None:
        await MapManagerModule(m, mgr, controller=args.controller, navigator=args.navigator, state_path=args.state,
                               map_name=map_name, resume=resume).run()

    return run_module(args.name, endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
