"""Landmark matching as an EDDIE process: position fixes from the landmarks in view, sent to the navigator.

`python -m eddie.modules.landmark_matching_module --vehicle V --map FILE --start-pose X,Y,YAW [--asleep]`

Seed: Navlab 1990 §2.5 — landmark matching runs between the triggers "start / stop landmark
matching" and sends fixes to the navigator. Each cycle: capture a frame (no truth), note the
controller's `local` pose then (the controller keeps no history, so the fix carries it), match the
map objects in view with PERCEPTION's object finder and calibrator around the believed pose, and
send a point or line fix.
"""

from __future__ import annotations

import argparse
import logging
import sys

from eddie.modules.args import parse_pose
from eddie.modules.landmark_matching import fix_message, landmark_fix
from eddie.modules.sensing import Belief, capture_frame, objects_in_view
from eddie.modules.switched import Switch, run_switched
from eddie.toolkit.module import Module
from eddie.toolkit.process import run_module
from modules.map_navigator import MapData, load_map
from modules.perception import PerceptionPipeline, ResolutionTable, colored_range_image
from modules.perception.monitor import SENSORS
from runtime.args import setup_logging
from wire.flags import add_network_args, network_from_args

__all__ = ["LandmarkMatching", "main", "build_parser"]

log = logging.getLogger("eddie.modules.landmark_matching")


class LandmarkMatching:
    """The landmark matching loop on one module endpoint."""

    def __init__(self, m: Module, map_data: MapData, *, vehicle: str, start: tuple[float, float, float],
                 awake: bool = True, period_s: float = 2.0) -> None:
        self.m = m
        self.map = map_data
        self.switch = Switch(awake)
        self.belief = Belief(m, start)
        self.pipeline = PerceptionPipeline(ResolutionTable(SENSORS[vehicle]))
        self.period_s = period_s

    async def cycle(self) -> str:
        """Match one frame; send the fix if there is one."""
        frame = await capture_frame(self.m)
        poses = await self.belief.at_capture(frame.stamp)
        if poses is None:
            return "no controller pose at the capture"
        local, prior = poses
        fix, why = landmark_fix(self.pipeline, colored_range_image(frame), objects_in_view(self.map, tuple(prior)), tuple(prior))
        if fix is None:
            return why
        msg = fix_message(fix, tuple(local), "landmark_matching")
        await self.m.send("navigator", msg)
        return f"{fix.kind} fix sent ({fix.n_used} observations)"

    async def run(self) -> None:
        """Sleep until woken, then match a frame every `period_s` [s] sim while awake."""
        await run_switched(self.m, self.switch, self.cycle, period_s=self.period_s)


def build_parser() -> argparse.ArgumentParser:
    """Return the module's argument parser (network flags included)."""
    p = argparse.ArgumentParser(prog="python -m eddie.modules.landmark_matching_module", description=__doc__.splitlines()[0])
    p.add_argument("--vehicle", choices=["navlab", "terregator"], default="terregator")
    p.add_argument("--map", required=True, help="the robot's map file (the landmarks)")
    p.add_argument("--start-pose", default="0,0,0", help="X,Y,YAW: world←local until the navigator says [m, m, rad]")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--period", type=float, default=2.0, help="one fix attempt per this much sim time [s]")
    p.add_argument("--asleep", action="store_true", help="start asleep (a trigger wakes it)")
    add_network_args(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run landmark matching until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging()
    net = network_from_args(parser, args)
    start = parse_pose(parser, args.start_pose)
    if not args.period > 0:
        parser.error("--period: must be > 0 [s]")
    try:
        map_data = load_map(args.map)
    except (FileNotFoundError, ValueError) as exc:
        parser.error(f"--map: {exc}")

    async def body(m: Module) -> None:
        await LandmarkMatching(m, map_data, vehicle=args.vehicle, start=start, awake=not args.asleep, period_s=args.period).run()

    return run_module("landmark_matching", body, net)


if __name__ == "__main__":
    sys.exit(main())
