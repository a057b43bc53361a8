"""Run FIDO obstacle stop: `python -m eddie.fido_stop --vehicle V [--asleep] [--stereo-size PX] [--min-features N]`."""

from __future__ import annotations

import argparse
import sys

from eddie.fido_stop.fido_stop import FidoStop
from eddie.obstacle_stop.__main__ import build_parser as obstacle_stop_parser, stop_config
from eddie.toolkit.module import Module, endpoint
from modules.fido.obstacle_watch import FidoWatchConfig
from modules.fido.watch_flags import add_watch_args, watch_values
from runtime import parse_module_args, run_module
from runtime.flags import config_from_flags

__all__ = ["main", "build_parser"]

_DESCRIPTION = "FIDO obstacle stop as an EDDIE process: stops the controller when FIDO's stereo sees something on its path"


def build_parser() -> argparse.ArgumentParser:
    """Return the module's argument parser: obstacle stop's (its name too, the triggers' address) and FIDO's flags."""
    p = obstacle_stop_parser("eddie.fido_stop", _DESCRIPTION)
    add_watch_args(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run FIDO obstacle stop until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args, net = parse_module_args(parser, argv)
    cfg = stop_config(parser, args)
    watch = config_from_flags(parser, FidoWatchConfig, watch_values(args))
    start = args.start_pose

    async def body(m: Module) -> None:
        await FidoStop(m, awake=not args.asleep, cfg=cfg, start=start, watch=watch).run()

    return run_module(args.name, endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
