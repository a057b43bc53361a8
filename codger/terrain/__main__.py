"""Run the TERRAIN module: `python -m codger.terrain --bounds X0,Y0,X1,Y1 [--vehicle navlab|terregator] [--resolution M] …`."""

from __future__ import annotations

import argparse
import sys

from pydantic import ValidationError

from codger.blackboard_part import BlackboardPart
from codger.terrain.terrain_module import TerrainModule, TerrainModuleConfig
from runtime import add_vehicle, module_parser, parse_module_args, run_module

__all__ = ["main", "build_parser"]


def _bounds(text: str) -> tuple[float, float, float, float]:
    try:
        x0, y0, x1, y1 = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X0,Y0,X1,Y1 in metres, got {text!r}") from None
    if not (x1 > x0 and y1 > y0):
        raise argparse.ArgumentTypeError(f"expected X1 > X0 and Y1 > Y0, got {text!r}")
    return x0, y0, x1, y1


def build_parser() -> argparse.ArgumentParser:
    """Return the TERRAIN module's argument parser (network flags included)."""
    p = module_parser("codger.terrain", __doc__)
    add_vehicle(p, default="navlab", help="vehicle whose limits mark the inadmissible cells")
    p.add_argument("--bounds", type=_bounds, required=True, help="the map's extent X0,Y0,X1,Y1 [m] in world")
    p.add_argument("--resolution", type=float, default=0.2, help="side of a map cell [m]")
    p.add_argument("--tile-cells", type=int, default=64, help="cells on a side of one terrain_tile token")
    p.add_argument("--period", type=float, default=0.5, help="seconds of sim time between laser images [s]")
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run the TERRAIN module until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    try:
        cfg = TerrainModuleConfig(vehicle=args.vehicle, bounds=args.bounds, resolution_m=args.resolution,
                                  tile_cells=args.tile_cells, period_s=args.period)
    except ValidationError as exc:
        parser.error("; ".join(f"--{str(e['loc'][0]).replace('_', '-')}: {e['msg']}" for e in exc.errors()))

    async def body(rt) -> None:
        await TerrainModule(rt, cfg).run()

    return run_module(args.name, body, net, parts=(BlackboardPart(),))


if __name__ == "__main__":
    sys.exit(main())
