"""Entry point of the CAPTAIN module: `python -m codger.captain [--mission FILE]... [Zenoh flags]`."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from modules.captain.missionfile import MissionFileError, load_mission
from codger.captain.service import Captain, CaptainOptions
from runtime import ModuleRuntime, add_heartbeat, module_parser, parse_module_args, run_module
from codger.blackboard_part import BlackboardPart
from modules.vocabulary import Mission

__all__ = ["main", "build_parser", "captain_main"]


def build_parser() -> argparse.ArgumentParser:
    """Return the CAPTAIN's argument parser."""
    p = module_parser("codger.captain", "Sidewalk CAPTAIN: missions → steps → status.")
    p.add_argument("--mission", action="append", default=[], type=Path, help="mission file to run at start (repeatable, in order)")
    p.add_argument("--navigator", default="map_navigator", help="module name of the MAP NAVIGATOR to supervise")
    p.add_argument("--navigator-grace", type=float, default=15.0, help="wall seconds the MAP NAVIGATOR may be gone before the mission fails")
    p.add_argument("--step-timeout", type=float, default=None, help="sim seconds a step may take (default: no limit)")
    p.add_argument("--ack-timeout", type=float, default=60.0,
                   help="wall seconds the navigator has to acknowledge a step with a route plan before the mission fails (0: no limit)")
    add_heartbeat(p)
    return p


def captain_main(missions: list[Mission], options: CaptainOptions):
    """Return the module main running the CAPTAIN with `missions` queued at start."""

    async def run(rt: ModuleRuntime) -> None:
        cap = Captain(rt, options)
        cap.declare()
        await cap.fail_orphans()
        for m in missions:
            await cap.accept(m)
        rt.ready()
        await cap.run()

    return run


def main(argv: list[str] | None = None) -> int:
    """Run the CAPTAIN until SIGINT/SIGTERM; return the exit code (2 for a bad mission file)."""
    args, net = parse_module_args(build_parser(), argv)
    missions = []
    for path in args.mission:
        try:
            missions.append(load_mission(path))
        except MissionFileError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
    options = CaptainOptions(navigator=args.navigator, navigator_grace_s=args.navigator_grace, step_timeout_s=args.step_timeout,
                             ack_timeout_s=args.ack_timeout or None)
    return run_module(args.name, captain_main(missions, options), net, parts=(BlackboardPart(),), heartbeat_period=args.heartbeat)


if __name__ == "__main__":
    sys.exit(main())
