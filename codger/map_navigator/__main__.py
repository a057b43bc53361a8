"""Entry point of the MAP NAVIGATOR: `python -m codger.map_navigator --map FILE|NAME [options] [Zenoh flags]`."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

from modules.map_navigator.mapdata import MapData, WorldFileError, load_map
from codger.map_navigator.service import MapNavigator, ServiceOptions
from modules.map_navigator.stepjob import NavigatorOptions
from runtime import ModuleRuntime, add_heartbeat, add_vehicle, module_parser, parse_module_args, run_module
from codger.blackboard_part import BlackboardPart

__all__ = ["main", "build_parser", "navigator_main", "start_position"]


def build_parser() -> argparse.ArgumentParser:
    """Return the MAP NAVIGATOR's argument parser."""
    p = module_parser("codger.map_navigator", "Sidewalk MAP NAVIGATOR: mission steps → route → route segments.")
    p.add_argument("--map", required=True, help="map file (GeoJSON), or a world name like campus for worlds/campus.map.geojson")
    add_vehicle(p, help="vehicle (stairs are impassable for the navlab)")
    p.add_argument("--start", default=None, help="start position X,Y [m] world frame, or a place name (default: the map's start)")
    p.add_argument("--max-replans", type=int, default=2, help="replans allowed per step after segment failures")
    p.add_argument("--pilot", default="pilot", help="module name of the PILOT to supervise")
    p.add_argument("--pilot-grace", type=float, default=15.0, help="wall seconds the PILOT may be gone before the segment fails")
    p.add_argument("--no-post-map", action="store_true", help="do not store the map objects on the blackboard (for monitors)")
    add_heartbeat(p)
    return p


def start_position(m: MapData, text: str | None) -> tuple[float, float]:
    """Return the start position [m]: "X,Y", a place name, or the map's start; raise ValueError."""
    if text is None:
        if m.world.start is None:
            raise ValueError(f"map {m.name!r} has no start; give --start X,Y or a place name")
        return (m.world.start.x, m.world.start.y)
    parts = text.split(",")
    if len(parts) == 2:
        try:
            return (float(parts[0]), float(parts[1]))
        except ValueError:
            pass
    node = m.find_place(text)
    if node is None:
        raise ValueError(f"--start {text!r} is neither X,Y nor a place of map {m.name!r} ({', '.join(m.place_names())})")
    return (node.x, node.y)


def navigator_main(m: MapData, start_xy: tuple[float, float], options: NavigatorOptions, service: ServiceOptions):
    """Return the module main running the MAP NAVIGATOR on map `m`."""

    async def run(rt: ModuleRuntime) -> None:
        nav = MapNavigator(rt, m, start_xy, options, service)
        rt.ready()
        await nav.run()

    return run


def main(argv: list[str] | None = None) -> int:
    """Run the MAP NAVIGATOR until SIGINT/SIGTERM; return the exit code (2 for a bad map or flag)."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    try:
        m = load_map(args.map)
    except (WorldFileError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        start = start_position(m, args.start)
    except ValueError as exc:
        parser.error(str(exc))
    if args.max_replans < 0:
        parser.error("--max-replans must be ≥ 0")
    options = replace(NavigatorOptions(), vehicle=args.vehicle, max_replans=args.max_replans)
    service = ServiceOptions(pilot=args.pilot, pilot_grace_s=args.pilot_grace, post_map=not args.no_post_map)
    return run_module(args.name, navigator_main(m, start, options, service), net, parts=(BlackboardPart(),), heartbeat_period=args.heartbeat)


if __name__ == "__main__":
    sys.exit(main())
