"""Obstacle stop as an EDDIE process: stops the controller when something stands on its path.

`python -m eddie.modules.obstacle_stop_module --vehicle V [--asleep]`

Seed: Navlab 1990 §2.5 — fast obstacle detection, started and stopped by triggers ("stop / start
fast obstacle detection"). Awake, each cycle reads a range image (the simulator's capture service,
no truth), and when an obstacle stands on the controller's path (its `path` stream, placed by the
controller's pose at the capture) it sends `Stop` to the controller as
the highest-priority client and holds control (a speed cap of 0); once the corridor is clear again
it lifts the cap and releases control, so the driving module's next path is taken. Each verdict goes out on its stream `seen`.
"""

from __future__ import annotations

import argparse
import logging
import sys

import numpy as np

from eddie.messages.controller import ControllerPath, Release, SpeedLimit, Stop
from eddie.messages.modules import ObstacleSeen
from eddie.modules.obstacle_stop import ObstacleStopConfig, obstacle_ahead
from eddie.modules.sensing import Belief, capture_frame
from eddie.modules.switched import Switch, run_switched
from eddie.toolkit.message import Message
from eddie.toolkit.module import Module
from eddie.toolkit.process import run_module
from modules.perception.obstacles import LaserScan
from modules.runtime.args import setup_logging
from wire.flags import add_network_args, network_from_args

__all__ = ["ObstacleStop", "main", "build_parser"]

log = logging.getLogger("eddie.modules.obstacle_stop")

#: the controller client name and priority of obstacle stop (above every driving module)
CLIENT, PRIORITY = "obstacle_stop", 10


class ObstacleStop:
    """The obstacle stop loop on one module endpoint."""

    def __init__(self, m: Module, *, awake: bool = True, cfg: ObstacleStopConfig = ObstacleStopConfig()) -> None:
        self.m = m
        self.cfg = cfg
        self.switch = Switch(awake)
        self.stopped = False
        self.belief = Belief(m, (0.0, 0.0, 0.0))  # only its `local` poses are used
        self.path: np.ndarray | None = None
        m.subscribe("controller", "path", ControllerPath, self._on_path)

    def _on_path(self, p: ControllerPath) -> None:
        self.path = np.asarray(p.path, dtype=np.float64).reshape(-1, 2) if p.path else None

    async def cycle(self) -> str:
        """Check one range image along the controller's path; stop or release the controller when the verdict changes."""
        frame = await capture_frame(self.m)
        if self.m.pending():
            return "inbox first"  # a trigger may have switched detection off while the frame came
        pose = self.belief.local_at(frame.stamp)
        if pose is None:
            return "no controller pose at the capture"
        seen = obstacle_ahead(LaserScan.from_capture(frame), self.cfg, path_local=self.path, pose_local=tuple(pose))
        self.m.publish("seen", ObstacleSeen(stamp=seen.stamp, blocked=seen.blocked, distance_m=seen.distance_m))
        if seen.blocked and not self.stopped:
            self.stopped = True
            await self.m.send("controller", Stop(client=CLIENT, priority=PRIORITY,
                                                 reason=f"obstacle {seen.distance_m:.1f} m ahead on the path"))
            # hold control (a speed cap of 0 at the top priority) so no driving module's path moves it on
            await self.m.send("controller", SpeedLimit(client=CLIENT, priority=PRIORITY, speed=0.0))
            return "stopped"
        if not seen.blocked and self.stopped:
            await self._release()
            return "released"
        return "blocked" if seen.blocked else "clear"

    async def _release(self) -> None:
        self.stopped = False
        await self.m.send("controller", SpeedLimit(client=CLIENT, priority=PRIORITY, speed=None))
        await self.m.send("controller", Release(client=CLIENT))

    async def on_trigger(self, _data: Message) -> None:
        """Lift a stop this module holds when a trigger switches detection off (it could not lift it asleep)."""
        if not self.switch.awake and self.stopped:
            log.info("obstacle_stop: detection switched off while holding a stop: released")
            await self._release()

    async def run(self) -> None:
        """Sleep until woken, then check every 0.5 s sim while awake."""
        await run_switched(self.m, self.switch, self.cycle, period_s=0.5, on_data=self.on_trigger)


def build_parser() -> argparse.ArgumentParser:
    """Return the module's argument parser (network flags included)."""
    p = argparse.ArgumentParser(prog="python -m eddie.modules.obstacle_stop_module", description=__doc__.splitlines()[0])
    p.add_argument("--vehicle", choices=["navlab", "terregator"], default="terregator")
    p.add_argument("--map", default=None, help="(accepted for a uniform command line; not used)")
    p.add_argument("--start-pose", default=None, help="(accepted for a uniform command line; not used)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--stop-distance", type=float, default=ObstacleStopConfig().stop_distance_m, help="stop for an obstacle this near along the path [m]")
    p.add_argument("--asleep", action="store_true", help="start asleep (a trigger wakes it)")
    add_network_args(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse flags and run obstacle stop until SIGINT/SIGTERM; return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging()
    net = network_from_args(parser, args)
    if not args.stop_distance > 0:
        parser.error("--stop-distance: must be > 0 [m]")
    cfg = ObstacleStopConfig(stop_distance_m=args.stop_distance)

    async def body(m: Module) -> None:
        await ObstacleStop(m, awake=not args.asleep, cfg=cfg).run()

    return run_module("obstacle_stop", body, net)


if __name__ == "__main__":
    sys.exit(main())
