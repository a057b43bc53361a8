"""The integrated controller's core (seed: Navlab 1990 §2.5), free of the network: commands in, drive commands out.

It tracks the commanded path in `local` with the HELM's pure-pursuit `PathTracker`; `immediate`
commands replace the path, `queued` ones are appended; speed changes ramp (`VelocityRegulator`); the
summed nudge offsets (`NudgeSum`) are added last; clients take control by priority (`ClientArbiter`);
the driven path is recorded (`PathRecord`) so it can be followed again by dead reckoning. The pose is
the odometry's: integrated in `local`, never corrected by fixes, so it never jumps. No pose history
is kept.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from modules.helm.tracker import Actuation, Lookahead, PathTracker, TrackCommand, TrackerConfig, TrackerError, drive_steps
from wire.drive import MAX_COMMAND_DURATION, DriveCommand, DriveStep, Odometry

from eddie.controller.arbiter import ClientArbiter
from eddie.controller.nudge import NudgeSum
from eddie.controller.path_record import PathRecord
from eddie.controller.velocity import VelocityRegulator
from eddie.messages.controller import (
    CommandAck, ControllerEvent, ControllerMode, ControllerPath, ControllerState, DeadReckon, Nudge, PathCommand,
    Position, Release, SpeedLimit, Stop,
)

__all__ = ["IntegratedController", "ControllerConfig", "ARC_OVERSHOOT_RAD"]

#: How far [rad] past its lookahead point's bearing a drive command's arc may turn the vehicle before
#: it lapses (`TrackerConfig.overshoot`). A late command (the controller held up 2 s sim at RTF 50) no
#: longer weaves the vehicle into a bench beside the walk: the campus tour at RTF 50 succeeded in 13 of
#: 16 runs with it, 9 of 16 without (docs/performance.md, session 20). The HELM's tracker leaves it
#: unset: CODGER did no better with it (9 of 12 against 12 of 12).
ARC_OVERSHOOT_RAD = 0.1

#: what the tracker gives with no path: stand
_STOP = TrackCommand(0.0, 0.0, 0.0, 0.0, True)


@dataclass(frozen=True)
class ControllerConfig:
    """Control rate [Hz sim], longest hold of one drive command [s sim], nudge decay [s sim], record spacing [m]."""

    tracker: TrackerConfig
    control_hz: float = 10.0
    max_hold_s: float = 2.0
    nudge_tau_s: float = 1.0
    record_spacing_m: float = 0.25


@dataclass
class _Path:
    points: list[tuple[float, float]]
    speeds: list[float]
    client: str
    mode: ControllerMode
    sensed_at: float | None = None


def _poses(points: list[tuple[float, float]]) -> np.ndarray:
    xy = np.asarray(points, dtype=np.float64)
    d = np.diff(xy, axis=0)
    yaw = np.arctan2(d[:, 1], d[:, 0])
    return np.column_stack([xy, np.append(yaw, yaw[-1])])


@dataclass
class IntegratedController:
    """The controller's state machine; feed it `odometry()`, `command()` and `tick()` with sim times [s]."""

    cfg: ControllerConfig
    events: list[ControllerEvent] = field(default_factory=list)

    def __post_init__(self) -> None:
        tr = self.cfg.tracker
        self.tracker = PathTracker(tr)
        self.lookahead = Lookahead(1.0 / self.cfg.control_hz, self.cfg.max_hold_s)
        self.velocity = VelocityRegulator(tr.max_accel, tr.max_decel)
        self.nudge = NudgeSum(self.cfg.nudge_tau_s)
        self.arbiter = ClientArbiter()
        self.record = PathRecord(self.cfg.record_spacing_m)
        self.odom: Odometry | None = None
        self.path: _Path | None = None
        #: the newest path a client offered while another held control (see `ControllerPath.offered`)
        self.offered: _Path | None = None
        self.mode: ControllerMode = "idle"
        self.speed_limit: float | None = None
        self.mission_speed: float | None = None
        self.curvature = 0.0
        self.path_changed = True
        self._seq = 0
        self._last_tick: float | None = None

    # ---- inputs --------------------------------------------------------------------------

    def odometry(self, od: Odometry) -> None:
        """Take the newest odometry (local←vehicle); older samples are ignored."""
        if self.odom is None or od.stamp >= self.odom.stamp:
            self.odom = od
            self.record.add(od.distance, od.x, od.y)

    def set_mission_speed(self, speed: float | None, now: float, why: str = "") -> None:
        """Cap every client's speed at `speed` [m/s] (None: no cap): the seed's "set speed" trigger.

        Kept apart from a client's `SpeedLimit` (an obstacle stop holds 0 there) so a trigger never lifts a stop.
        """
        self.mission_speed = speed
        self._event(now, "set_speed", "map_manager", ("none" if speed is None else f"{speed:g} m/s") + (f" ({why})" if why else ""))

    def _event(self, now: float, kind: str, client: str = "", detail: str = "") -> None:
        self.events.append(ControllerEvent(stamp=now, kind=kind, client=client, detail=detail))

    def _refuse(self, now: float, client: str, kind: str, reason: str) -> CommandAck:
        self._event(now, "refused", client, f"{kind}: {reason}")
        return CommandAck(accepted=False, reason=reason, holder=self.arbiter.holder)

    def command(self, msg: object, now: float) -> CommandAck:
        """Apply a command at sim time `now` [s]; return whether it was accepted and why not."""
        if isinstance(msg, Nudge):
            self.nudge.set(msg.source, msg.dv, msg.dk, now)
            return CommandAck(accepted=True, holder=self.arbiter.holder)
        if isinstance(msg, Release):
            if not self.arbiter.release(msg.client):
                return self._refuse(now, msg.client, "release", f"{msg.client!r} does not hold control")
            self._event(now, "released", msg.client)
            return CommandAck(accepted=True, holder=None)
        if isinstance(msg, Stop):  # any client may stop the vehicle
            self.path = None
            self.tracker.clear()
            self.velocity.reset(0.0)
            self.mode = "stopped"
            self.path_changed = True
            self._event(now, "stop", msg.client, msg.reason)
            return CommandAck(accepted=True, holder=self.arbiter.holder)
        if not isinstance(msg, (PathCommand, DeadReckon, SpeedLimit)):
            return self._refuse(now, "", type(msg).__name__, "not a controller command")
        ok, why = self.arbiter.request(msg.client, msg.priority)
        if not ok:
            if isinstance(msg, PathCommand):
                self.offered = _Path([tuple(p) for p in msg.points], [], msg.client, "tracking", msg.sensed_at)
                self.path_changed = True
            return self._refuse(now, msg.client, type(msg).__name__, why)
        if isinstance(msg, SpeedLimit):
            self.speed_limit = msg.speed
            self._event(now, "speed_limit", msg.client, "none" if msg.speed is None else f"{msg.speed:g} m/s")
            return CommandAck(accepted=True, holder=self.arbiter.holder)
        if isinstance(msg, PathCommand):
            pts = [tuple(p) for p in msg.points]
            speeds = list(msg.speeds) if msg.speeds is not None else [msg.speed] * len(pts)
            new = _Path(pts, speeds, msg.client, "tracking", msg.sensed_at)
        else:
            if msg.points is not None:
                pts = [tuple(p) for p in msg.points]
            else:
                pts = self.record.stretch(msg.odometer_from, msg.odometer_to)  # type: ignore[arg-type]
                if len(pts) < 2:
                    return self._refuse(now, msg.client, "DeadReckon",
                                        f"no recorded path between odometer {msg.odometer_from:g} and {msg.odometer_to:g} m")
            new = _Path(pts, [msg.speed] * len(pts), msg.client, "dead_reckon", None)
        if msg.mode == "queued" and self.path is not None:
            cur = self.path
            skip = 1 if math.dist(cur.points[-1], new.points[0]) < 1e-3 else 0
            new = _Path(cur.points + new.points[skip:], cur.speeds + new.speeds[skip:], new.client, new.mode,
                        new.sensed_at if new.sensed_at is not None else cur.sensed_at)
        try:
            self.tracker.set_plan(_poses(new.points), np.asarray(new.speeds))
        except TrackerError as exc:
            return self._refuse(now, msg.client, type(msg).__name__, str(exc))
        self.path = new
        self.offered = None
        self.mode = new.mode
        self.path_changed = True
        self._event(now, f"{msg.mode}_{new.mode}", msg.client, f"{len(new.points)} points")
        return CommandAck(accepted=True, holder=self.arbiter.holder)

    # ---- outputs -------------------------------------------------------------------------

    def _shape(self, cmd: TrackCommand, dt: float, velocity: VelocityRegulator) -> Actuation:
        """Return what is sent for the tracker's `cmd` after `dt` [s]: speed capped, then ramped by `velocity`."""
        speed, turn_rate = cmd.speed, cmd.turn_rate
        for cap in (self.speed_limit, self.mission_speed):
            if cap is not None:
                speed = max(-cap, min(cap, speed))
        if turn_rate is not None:  # the tracker turns a skid-steer vehicle on the spot
            velocity.reset(0.0)
            speed = 0.0
        return Actuation(velocity.step(speed, dt), cmd.curvature, turn_rate)

    def tick(self, now: float) -> DriveCommand:
        """Return the drive command for sim time `now` [s] (a stop without odometry or a path).

        While tracking, the commands of the next `max_hold_s` [s] along the path follow it (`then`,
        `modules.helm.tracker.Lookahead`): a controller held up leaves the vehicle on its path.
        """
        dt = 0.0 if self._last_tick is None else max(0.0, now - self._last_tick)
        self._last_tick = now
        tr = self.cfg.tracker
        od = self.odom
        cmd = _STOP
        if od is not None and self.path is not None:
            cmd = self.tracker.command(od.to_pose2d().as_array(), dt)
            if cmd.done:
                self._event(now, "path_done", self.path.client, self.path.mode)
                self.path = None
                self.tracker.clear()
                self.mode = "idle"
                self.path_changed = True
                cmd = _STOP
        act = self._shape(cmd, dt, self.velocity)
        speed, curv, horizon = act.speed, act.curvature, cmd.horizon
        dv, dk = self.nudge.offsets(now)
        nudged = bool(dv or dk)
        if nudged:
            speed = max(-tr.max_speed, min(tr.max_speed, speed + dv))
            curv = max(-tr.max_curvature, min(tr.max_curvature, curv + dk))
            horizon = min(horizon, 1.0 / self.cfg.control_hz * 1.5)
            act = Actuation(speed, curv, act.turn_rate)
        self.curvature = curv
        moving = act.moving
        period = 1.0 / self.cfg.control_hz
        duration = float(min(self.cfg.max_hold_s, max(1.5 * period, horizon))) if moving else MAX_COMMAND_DURATION
        then: tuple[DriveStep, ...] = ()
        if moving and not nudged and od is not None and self.path is not None:
            velocity = copy.copy(self.velocity)  # the look ahead ramps a copy of the speed
            ahead = self.lookahead.steps(now, self.tracker, od.to_pose2d().as_array(), act,
                                         lambda c, step: self._shape(c, step, velocity))
            if ahead:
                duration = period
                then = drive_steps(ahead)
        else:
            self.lookahead.reset()  # a nudge is summed in as it comes: only the command in hand carries it
        self._seq += 1
        return DriveCommand(speed=speed, curvature=curv, mode="immediate", turn_rate=act.turn_rate if moving else None,
                            seq=self._seq, duration=duration, then=then,
                            sensed_at=self.path.sensed_at if self.path is not None else None)

    def position(self) -> Position | None:
        """Return the dead-reckoned pose now (the newest odometry), or None before the first."""
        od = self.odom
        if od is None:
            return None
        return Position(stamp=od.stamp, x=od.x, y=od.y, yaw=od.yaw, v=od.v)

    def state(self, now: float) -> ControllerState:
        """Return the controller's state for its `state` stream."""
        od = self.odom
        x, y, yaw, v, dist = (od.x, od.y, od.yaw, od.v, od.distance) if od is not None else (0.0, 0.0, 0.0, 0.0, 0.0)
        return ControllerState(stamp=od.stamp if od is not None else now, x=x, y=y, yaw=yaw, v=v, curvature=self.curvature,
                               client=self.arbiter.holder or "", mode=self.mode, odometer=dist, speed_limit=self.speed_limit,
                               mission_speed=self.mission_speed)

    def path_message(self, now: float) -> ControllerPath:
        """Return the tracked path for the `path` stream (clears the changed flag)."""
        self.path_changed = False
        p, o = self.path, self.offered
        return ControllerPath(stamp=now, path=tuple(p.points) if p else (), client=p.client if p else "",
                              mode=self.mode, offered=tuple(o.points) if o else (), offered_client=o.client if o else "")

    def take_events(self) -> list[ControllerEvent]:
        """Return and forget the events since the last call."""
        ev, self.events = self.events, []
        return ev
