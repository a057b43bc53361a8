"""Obstacle stop as an EDDIE process: stops the controller when something stands on its path.

`python -m eddie.obstacle_stop --vehicle V [--asleep]`

Seed: Navlab 1990 §2.5 — fast obstacle detection, started and stopped by triggers ("stop / start
fast obstacle detection"). Awake, each cycle reads a range image (the simulator's capture service,
no truth), and when an obstacle stands on the controller's path (its `path` stream, placed by the
controller's pose at the capture) it sends `Stop` to the controller as
the highest-priority client and holds control (a speed cap of 0); once the corridor is clear again
it lifts the cap and releases control, so the driving module's next path is taken. While it holds, the
driving module's newer paths are refused by the controller, which shows the newest of them as its path
stream's `offered`; a hold is also lifted when that path is clear, so a stop on a path that went wrong (an
estimate that was off, a road seen wrongly) does not outlast the path that replaced it. A "stop at
object" trigger (the mission's stop at the mailbox) stops the vehicle at its goal point and holds
it (action `stop`) or waits and lets it go (`wait`). Each verdict goes out on its stream `seen`.
"""

from __future__ import annotations

import asyncio
import math
import logging

import numpy as np

from eddie.messages.controller import ControllerPath, Release, SpeedLimit, Stop
from eddie.messages.map_manager import StopAtObject
from eddie.messages.modules import ObjectStopped, ObstacleSeen
from eddie.obstacle_stop.obstacle_stop import ObstacleReport, ObstacleStopConfig, obstacle_ahead
from eddie.modules.sensing import Belief, CaptureError, capture_scan
from eddie.obstacle_stop.stop_at_object import ObjectCorrection, sight_object
from eddie.modules.switched import Switch, run_switched
from eddie.toolkit.message import Message
from eddie.toolkit.module import Module
from modules.perception.obstacles import LaserScan, detect_obstacles
from modules.pilot import pilot_config_for

__all__ = ["ObstacleStop", "corridor_half_width", "stop_now"]

log = logging.getLogger("eddie.obstacle_stop.obstacle_stop")

#: the controller client name and priority of obstacle stop (above every driving module)
CLIENT, PRIORITY = "obstacle_stop", 10

#: the body's reach ahead of the vehicle's origin [m]: the Navlab's origin is its rear axle, the Terregator's its centre
BODY_FRONT_M = {"navlab": 4.6, "terregator": 1.1}
#: "stop at object": stop this far inside the goal's tolerance [m], and never farther than this when the tolerance is small [m]
STOP_AT_MARGIN_M, STOP_AT_NEAR_M = 0.3, 0.3
#: the time [s] sim from a believed pose to the controller braking (the watch's period and the message)
STOP_LATENCY_S = 0.3
#: the laser's frame period [s] sim (the ERIM's 2 frames/s): the check and the look for a stop's object each take one frame a period
FRAME_PERIOD_S = 0.5
#: a check may look at a scan up to this old [s sim]: one the simulator rendered for road following (5 frames/s)
#: serves, so an instant is rendered once (issue 39); the verdict pairs it with the pose at its own stamp
SHARED_SCAN_AGE_S = 0.2


class ObstacleStop:
    """The obstacle stop loop on one module endpoint."""

    def __init__(self, m: Module, *, awake: bool = True, cfg: ObstacleStopConfig = ObstacleStopConfig(),
                 start: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        self.m = m
        self.cfg = cfg
        self.switch = Switch(awake)
        self.stopped = False
        self.holding_at: str | None = None  # the object a "stop at object" trigger holds the vehicle at
        self._watch: asyncio.Task | None = None
        self.belief = Belief(m, start)
        self.path: np.ndarray | None = None
        #: the newest path a driving module offered while this module held control (`local` [m]), and from whom
        self.offered: np.ndarray | None = None
        self.offered_client = ""
        self._frame: LaserScan | None = None
        m.subscribe("controller", "path", ControllerPath, self._on_path)

    def _on_path(self, p: ControllerPath) -> None:
        self.offered = np.asarray(p.offered, dtype=np.float64).reshape(-1, 2) if len(p.offered) >= 2 else None
        self.offered_client = p.offered_client
        if not p.path and self.stopped:
            # the controller dropped its path because this module stopped it: keep watching the path it stopped
            # on (straight ahead instead would take in the kerb when the vehicle stands at an angle)
            return
        self.path = np.asarray(p.path, dtype=np.float64).reshape(-1, 2) if p.path else None

    async def cycle(self) -> str:
        """Check one range image along the controller's path; stop or release the controller when the verdict changes."""
        taken = self.switch.taken
        frame = await self.capture()
        poses = await self.belief.at_capture(frame.stamp)
        if self.switch.taken != taken or not self.switch.awake:
            return "a trigger came while the frame did"  # it may have switched detection off
        if poses is None:
            return "no controller pose at the capture"
        seen = await self.look(frame, tuple(float(v) for v in poses[0]))
        self.m.publish("seen", ObstacleSeen(stamp=seen.stamp, blocked=seen.blocked, distance_m=seen.distance_m))
        if seen.blocked and not self.stopped:
            self.stopped = True
            await self._hold(f"obstacle {seen.distance_m:.1f} m ahead on the path")
            return "stopped"
        if not seen.blocked and self.stopped:
            await self._release()
            return "released"
        if seen.blocked and self.stopped and self.holding_at is None and self.offered is not None:
            if not self.along(self.offered, tuple(float(v) for v in poses[0])).blocked:
                log.info("obstacle_stop: t=%.2f the path held is blocked %.1f m ahead, but %s's newer path is clear: released",
                         self.m.clock.now_or(-1.0), seen.distance_m, self.offered_client or "a client")
                await self._release()
                return "released for a newer path"
        return "blocked" if seen.blocked else "clear"

    async def capture(self) -> LaserScan:
        """Ask the simulator for the frame a check looks at (the laser's range image); raise CaptureError."""
        return await capture_scan(self.m, max_age_s=SHARED_SCAN_AGE_S)

    async def look(self, frame: LaserScan, pose: tuple[float, float, float]) -> ObstacleReport:
        """Return the verdict on `frame`, seen at the controller's `pose` (`local`), along the controller's path."""
        self._frame = frame
        return obstacle_ahead(frame, self.cfg, path_local=self.path, pose_local=pose, speed=self.belief.speed)

    def along(self, path: np.ndarray, pose: tuple[float, float, float]) -> ObstacleReport:
        """Return the verdict of the last `look`'s frame along another `path` (`local` [m]), seen at `pose` (`local`)."""
        return obstacle_ahead(self._frame, self.cfg, path_local=path, pose_local=pose, speed=self.belief.speed)

    async def _hold(self, reason: str) -> None:
        await self.m.send("controller", Stop(client=CLIENT, priority=PRIORITY, reason=reason))
        # hold control (a speed cap of 0 at the top priority) so no driving module's path moves it on
        await self.m.send("controller", SpeedLimit(client=CLIENT, priority=PRIORITY, speed=0.0))

    async def _release(self) -> None:
        self.stopped = False
        if self.holding_at is not None:
            return  # a "stop at object" holds the vehicle: the obstacle clearing does not lift it
        await self.m.send("controller", SpeedLimit(client=CLIENT, priority=PRIORITY, speed=None))
        await self.m.send("controller", Release(client=CLIENT))

    async def stop_at(self, target: StopAtObject) -> None:
        """Stop at the object's goal point (nearest approach within its tolerance), then hold, wait or go on.

        The believed pose (navigator ∘ controller) is watched every 0.1 s sim: the vehicle stops once
        within `STOP_AT_NEAR_M` [m] of the point, once the point is no farther ahead than the travel
        in `STOP_LATENCY_S` (and within the tolerance less `STOP_AT_MARGIN_M` [m] across), or
        inside that reach once the distance grows again (it passed its nearest approach); a path that
        ends at the point stops the vehicle there first. When the map has the object itself, the laser looks for it on
        the way in and the believed position is corrected by where the object is seen
        (`eddie.obstacle_stop.stop_at_object`).
        """
        reach = max(target.tolerance - STOP_AT_MARGIN_M, STOP_AT_NEAR_M)
        best = math.inf
        corr = ObjectCorrection()
        sighting = asyncio.ensure_future(self._sight(target.object_xy, corr)) if target.object_xy is not None else None
        if sighting is not None:
            sighting.add_done_callback(_log_failure)
        try:
            while True:
                pose = self.belief.world()
                if pose is not None:
                    x, y = corr.corrected(pose)
                    d = math.hypot(x - target.x, y - target.y)
                    if d <= STOP_AT_NEAR_M or (d <= reach and d > best + 0.05) \
                            or stop_now(target.x - x, target.y - y, float(pose[2]), self.belief.speed, reach):
                        break
                    best = min(best, d)
                await self.m.clock.sleep(0.1)
        finally:
            if sighting is not None:
                sighting.cancel()
        self.holding_at = target.object_id
        cx, cy = corr.correction
        log.info("obstacle_stop: at %s (%.2f m from its goal point; %d sightings moved the belief by (%.2f, %.2f) m): %s",
                 target.object_id, d, corr.seen, cx, cy, target.action)
        self.m.publish("object_stop", ObjectStopped(stamp=self.m.now(), object_id=target.object_id, distance_m=d,
                                                    sightings=corr.seen, correction=(cx, cy)))
        await self._hold(f"{target.action} at {target.object_id}")
        if target.action == "wait":
            await self.m.clock.sleep(target.wait_s)
            self.holding_at = None
            await self._release()

    async def _sight(self, object_xy: tuple[float, float], corr: ObjectCorrection) -> None:
        """Look for the map's object at `object_xy` (`world` [m]) in a range image every `FRAME_PERIOD_S` [s] sim until cancelled.

        Paced by the sim clock, not by the capture's round trip: in lock-step a capture is served at the
        same sim time, and a loop asking for the next frame at once never let the step end.
        """
        while True:
            due = self.m.clock.now() + FRAME_PERIOD_S
            try:
                scan = await capture_scan(self.m)
            except CaptureError as exc:
                log.warning("obstacle_stop: no frame to look for the object in: %s", exc)
            else:
                poses = await self.belief.at_capture(scan.stamp)
                if poses is not None:
                    pose = poses[1]
                    obstacles = await asyncio.to_thread(detect_obstacles, scan)
                    corr.add(sight_object(obstacles, object_xy, (float(pose[0]), float(pose[1]), float(pose[2])), scan.stamp))
            await self.m.clock.wait_until(due)

    async def on_trigger(self, data: Message) -> None:
        """Act on a trigger's data: watch for a "stop at object"; lift a stop held when detection is switched off."""
        if isinstance(data, StopAtObject):
            if data.action != "continue":
                if self._watch is not None:
                    self._watch.cancel()
                self._watch = asyncio.ensure_future(self.stop_at(data))
            return
        if not self.switch.awake and self.stopped:
            log.info("obstacle_stop: detection switched off while holding a stop: released")
            await self._release()

    async def run(self) -> None:
        """Sleep until woken, then check every 0.5 s sim while awake."""
        await run_switched(self.m, self.switch, self.cycle, period_s=FRAME_PERIOD_S, on_data=self.on_trigger)


def stop_now(dx: float, dy: float, yaw: float, speed: float, reach: float, latency_s: float = STOP_LATENCY_S) -> bool:
    """Return whether to stop now: the goal lies (dx, dy) [m] `world` from the vehicle heading `yaw` [rad] at `speed`
    [m/s], within `reach` [m] across the heading, and no farther ahead than the travel in `latency_s` [s] (or behind).

    The controller's stop is immediate (the vehicle's own braking, not the tracker's ramp): in the runs a
    braking-distance lead, v²/2a at the tracker's deceleration, stopped the Navlab 1–2 m short.
    """
    along = dx * math.cos(yaw) + dy * math.sin(yaw)
    across = abs(-dx * math.sin(yaw) + dy * math.cos(yaw))
    return across <= reach and along <= abs(speed) * latency_s


def _log_failure(task: asyncio.Task) -> None:
    if not task.cancelled() and task.exception() is not None:
        log.error("obstacle_stop: looking for the object failed: %r", task.exception())


def corridor_half_width(vehicle: str) -> float:
    """Return the default corridor half width [m]: the clearance the PILOT keeps from obstacles for `vehicle`.

    The same clearance as CODGER's planner, so a bench beside a walk that the PILOT passes does not
    stop EDDIE for good (the OBSTACLE DETECTOR's 1.5 m took in benches 1.5 m from a walk's centre).
    """
    return pilot_config_for(vehicle).navigator.obstacle_clearance
