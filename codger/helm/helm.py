"""The HELM process: track the newest local path plan, drive the vehicle, post the moving vehicle position.

Reads odometry (local←vehicle) from the simulator's drive interface and local path plans (frame
`local`) from the blackboard; sends timed DriveCommands (speed [m/s], curvature [1/m], duration [s])
on the drive key, each with the commands predicted for the next `max_hold_s` behind it (a HELM held up leaves the
vehicle on its plan: `modules.helm.tracker.Lookahead`), and posts `local←vehicle` poses at `pose_hz` (sim time), every one: the odometry of each
pose period is queued as it arrives and posted at the next control tick, so a HELM that fell behind (a
loaded machine at a high RTF) leaves no holes in the pose history a delayed fix is propagated through,
and the poses of one tick share a message. Whenever a new plan appears the old one is dropped (seed
§2.3.4). With no plan, or at its end, it commands stops. It also stops while the newest
`obstacle_report` says something stands on the plan ahead, and drives on once a newer one says clear.
"""

from __future__ import annotations

import asyncio
import logging
import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from blackboard import Pose2D, Spec
from blackboard.errors import BlackboardError
from modules.helm.tracker import Actuation, Lookahead, PathTracker, TrackerConfig, TrackerError, drive_steps, tracker_config_for
from modules.vocabulary import LocalPathPlan, ObstacleReport
from wire.keys import root as keys_root
from wire.ratelimit import warn_limited
from wire.timemode import lockstep_enabled
from wire.drive import MAX_COMMAND_DURATION, DriveCommand, Odometry, WireError, decode, encode

__all__ = ["HelmConfig", "Helm", "helm_config_for", "DriveKeys", "MAX_POSES_IN_FLIGHT"]

log = logging.getLogger(__name__)

#: Poses posted and not yet acknowledged, at most; beyond it (the blackboard away) odometry is not posted.
MAX_POSES_IN_FLIGHT = 256


def _as_sent(cmd, _dt: float) -> Actuation:
    """Return what the HELM sends for a tracker command: the command as it is."""
    return Actuation(cmd.speed, cmd.curvature, cmd.turn_rate)


class DriveKeys(BaseModel):
    """Zenoh keys of the simulator's drive interface, relative to `sidewalk/<ns>/`."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    command: str = "sim/cmd"
    odometry: str = "sim/odom"

    def resolve(self, namespace: str) -> tuple[str, str]:
        """Return the absolute (command, odometry) keys in `namespace`."""
        root = keys_root(namespace)
        return f"{root}/{self.command}", f"{root}/{self.odometry}"


class HelmConfig(BaseModel):
    """HELM settings: control and pose rates [Hz] (sim time), tracker, drive keys."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    vehicle: Literal["navlab", "terregator"] = "navlab"
    control_hz: float = Field(10.0, ge=10.0, description="drive commands (and poses) per sim second [Hz] (≥ 10)")
    pose_hz: float = Field(10.0, ge=10.0, description="local←vehicle poses per sim second [Hz] (≥ 10)")
    pose_hold_s: float = Field(0.5, ge=0.0, description="the newest pose answers lookups this long [s]")
    resume_plan_age_s: float = Field(5.0, ge=0.0, description="on start, resume a plan at most this old [s] sim")
    max_hold_s: float = Field(
        2.0, gt=0.0, le=MAX_COMMAND_DURATION,
        description="longest a driving command holds without a newer one [s] sim (it holds as far as its arc stays on the plan)",
    )
    tracker: TrackerConfig = TrackerConfig()
    keys: DriveKeys = DriveKeys()
    obstacle_stop_m: float = Field(20.0, ge=0.0, description="stop for a blocking obstacle report this near along the plan [m]")
    obstacle_stale_s: float = Field(10.0, gt=0.0, description="a blocking report older than this no longer stops the vehicle [s] sim (a dead detector must not stop it for ever; a slow one must not let it creep)")


def helm_config_for(vehicle: Literal["navlab", "terregator"], **overrides) -> HelmConfig:
    """Return the HELM preset for `vehicle` (Navlab: 7 m turning radius; Terregator: turns in place)."""
    base = dict(vehicle=vehicle, tracker=tracker_config_for(vehicle))
    base.update({k: v for k, v in overrides.items() if v is not None})
    return HelmConfig(**base)


class Helm:
    """Run the HELM on a module runtime `rt` (Zenoh link `rt.link`, blackboard `rt.bb`, clock `rt.clock`)."""

    def __init__(self, rt, cfg: HelmConfig) -> None:
        """Prepare the tracker; nothing touches the network until run()."""
        self.rt = rt
        self.cfg = cfg
        self.tracker = PathTracker(cfg.tracker)
        self.lookahead = Lookahead(1.0 / cfg.control_hz, cfg.max_hold_s)
        self.cmd_key, self.odom_key = cfg.keys.resolve(rt.net.namespace)
        self.odom: Odometry | None = None
        self._odom_event = asyncio.Event()
        self._seq = 0
        self._last_pose_stamp = -math.inf
        self.plans_taken = 0
        self.bad_payloads = 0
        self.plan_seq: int | None = None
        self.plan_sensed_at: float | None = None
        self.last_command: DriveCommand | None = None
        self.obstacle: ObstacleReport | None = None
        self.obstacle_stops = 0
        self._held = False
        self.poses_posted = 0
        self.poses_dropped = 0
        self._poses_in_flight = 0
        self._pose_queue: list[Odometry] = []
        #: lock-step: post each pose as its odometry arrives (the simulator announces sim time t only once the
        #: pose of t is on the blackboard), not when the control loop wakes at t beside the modules reading it
        self._pose_on_odom = lockstep_enabled()

    def _on_odom(self, _key: str, payload: bytes) -> None:
        try:
            od = decode(Odometry, payload)
        except WireError as exc:
            self.bad_payloads += 1
            log.warning("helm: bad odometry on %s: %s", self.odom_key, exc)
            return
        if self.odom is None or od.stamp >= self.odom.stamp:
            self.odom = od
            self._odom_event.set()
            if self.rt.is_ready:
                self._queue_pose(od)
                if self._pose_on_odom:
                    self._post_poses()

    def _queue_pose(self, od: Odometry) -> None:
        """Queue `od` to be posted as the moving vehicle position if a pose period passed since the last one queued."""
        if od.stamp - self._last_pose_stamp >= 1.0 / self.cfg.pose_hz - 1e-6:
            self._last_pose_stamp = od.stamp
            self._pose_queue.append(od)

    def _post_poses(self) -> None:
        """Post every queued pose, oldest first, without waiting: issued together, they leave in one message."""
        queue, self._pose_queue = self._pose_queue, []
        for od in queue:
            if self._poses_in_flight >= MAX_POSES_IN_FLIGHT:
                self.poses_dropped += 1
                warn_limited(log, "helm-poses", "helm: %d poses unacknowledged (blackboard away?): odometry not posted",
                             self._poses_in_flight)
                continue
            self._poses_in_flight += 1
            fut = self.rt.bb.post_pose(parent="local", child="vehicle", pose=Pose2D(x=od.x, y=od.y, yaw=od.yaw),
                                       stamp=od.stamp, hold=self.cfg.pose_hold_s)
            fut.add_done_callback(self._pose_done)

    def _pose_done(self, fut: asyncio.Future) -> None:
        self._poses_in_flight -= 1
        exc = None if fut.cancelled() else fut.exception()
        if exc is None:
            self.poses_posted += 1
        else:
            warn_limited(log, "helm-pose-failed", "helm: posting the moving vehicle position failed: %s", exc)

    def take_plan(self, plan: LocalPathPlan) -> bool:
        """Replace the plan being tracked with `plan` (frame local); return False if unusable."""
        if plan.frame != "local":
            log.warning("helm: ignoring plan %d in frame %s (the HELM tracks in local)", plan.seq, plan.frame)
            return False
        poses = np.array([[p.x, p.y, p.yaw] for p in plan.poses], dtype=np.float64)
        speeds = np.array([p.speed for p in plan.poses], dtype=np.float64)
        try:
            self.tracker.set_plan(poses, speeds)
        except TrackerError as exc:
            log.warning("helm: plan %d rejected: %s", plan.seq, exc)
            return False
        self.plans_taken += 1
        self.plan_seq = plan.seq
        self.plan_sensed_at = plan.sensed_at
        return True

    def command_duration(self, horizon: float, moving: bool) -> float:
        """Return how long [s] sim a command holds: a stop the longest allowed, a move its horizon.

        Every command is timed, so the simulator's watchdog (for open-ended commands) is only the last
        resort: a move holds for its horizon (at least 1.5 control periods, at most `max_hold_s`) and
        the vehicle stops by itself when no newer command follows, while a late command (a loaded
        machine, the simulator catching up on sim time in a burst) no longer stops a vehicle whose
        arc is still on the plan.
        """
        if not moving:
            return MAX_COMMAND_DURATION
        period = 1.0 / self.cfg.control_hz
        return float(min(self.cfg.max_hold_s, max(1.5 * period, horizon)))

    def _send(self, speed: float, curvature: float, turn_rate: float | None = None, horizon: float = math.inf,
              then: list[tuple[Actuation, float]] | None = None) -> None:
        """Send one drive command; `then`: the steps predicted behind it (`rollout`), the command then holds one period."""
        self._seq += 1
        moving = Actuation(speed, curvature, turn_rate).moving
        steps = drive_steps(then or [])
        duration = 1.0 / self.cfg.control_hz if moving and steps else self.command_duration(horizon, moving)
        cmd = DriveCommand(speed=speed, curvature=curvature, mode="immediate", turn_rate=turn_rate, seq=self._seq,
                           duration=duration, sensed_at=self.plan_sensed_at, then=steps if moving else ())
        self.last_command = cmd
        self.rt.link.put(self.cmd_key, encode(cmd))

    async def _plans(self) -> None:
        async for ev in self.rt.bb.monitor(Spec(type="local_path_plan")):
            if ev.kind == "new":
                self.take_plan(ev.token.attrs)

    async def _obstacles(self) -> None:
        async for ev in self.rt.bb.monitor(Spec(type="obstacle_report")):
            if ev.kind == "new" and (self.obstacle is None or ev.token.attrs.sensed_at >= self.obstacle.sensed_at):
                self.obstacle = ev.token.attrs

    def obstacle_hold(self, now: float) -> bool:
        """Return True while the newest obstacle report (fresh) blocks the plan within `obstacle_stop_m` [m]."""
        o = self.obstacle
        hold = o is not None and o.blocked and o.distance_m <= self.cfg.obstacle_stop_m and now - o.sensed_at <= self.cfg.obstacle_stale_s
        if hold and not self._held:
            self.obstacle_stops += 1
            log.info("helm: obstacle %.1f m ahead on the plan: stopping", o.distance_m)  # type: ignore[union-attr]
        elif self._held and not hold:
            log.info("helm: path clear: driving on")
        self._held = hold
        return hold

    async def run(self) -> None:
        """Track plans until the runtime asks to stop; always leave the vehicle commanded to stop."""
        rt = self.rt
        rt.link.subscribe(self.odom_key, self._on_odom)
        await rt.clock.wait_running()
        await self._odom_event.wait()
        plan_task = asyncio.ensure_future(self._plans())
        obstacle_task = asyncio.ensure_future(self._obstacles())
        # Take the newest plan already on the blackboard (a restarted HELM picks up where it was).
        try:
            toks = await rt.bb.retrieve(Spec(type="local_path_plan", newest=True))
            if toks and toks[0].stamp >= rt.clock.now() - self.cfg.resume_plan_age_s:
                self.take_plan(toks[0].attrs)
        except BlackboardError as exc:
            log.warning("helm: cannot read the newest plan: %s", exc)
        rt.ready()
        self._queue_pose(self.odom)
        self._post_poses()
        period = 1.0 / self.cfg.control_hz
        last_t = rt.clock.now()
        try:
            while not rt.stopping:
                od = self.odom
                now = rt.clock.now()
                dt = max(0.0, now - last_t)
                last_t = now
                pose = np.array([od.x, od.y, od.yaw])
                cmd = self.tracker.command(pose, dt)
                if not cmd.done and self.obstacle_hold(now):
                    self.tracker.halt()
                    self._send(0.0, 0.0)
                elif cmd.done:
                    self._send(0.0, 0.0)
                else:
                    # the commands of the next max_hold_s along the plan go behind this one: a HELM held up
                    # (two loaded cores at RTF 50) leaves the vehicle following the plan, not holding one arc
                    first = Actuation(cmd.speed, cmd.curvature, cmd.turn_rate)
                    ahead = self.lookahead.steps(now, self.tracker, pose, first, _as_sent)
                    self._send(cmd.speed, cmd.curvature, cmd.turn_rate, cmd.horizon, then=ahead)
                # the poses go out without holding up control: the drive command never waits for the
                # blackboard's acknowledgement (at a high RTF the watchdog would stop the vehicle)
                self._post_poses()
                await rt.clock.sleep(period)
        finally:
            plan_task.cancel()
            obstacle_task.cancel()
            try:
                self._send(0.0, 0.0)
            except Exception as exc:  # the session may already be closing
                log.warning("helm: final stop command not sent: %s", exc)
