"""HELM core: pure pursuit with speed-dependent lookahead and a curvature clamp, on the `local` frame.

The plan is a pose sequence (N,3) (x [m], y [m], yaw [rad]) with signed speeds (N,) [m/s]; the
vehicle pose is local←vehicle from odometry. Each call returns a speed [m/s] and a curvature
[1/m] for the drive interface, slowing so that the vehicle comes to rest at the plan's end.

`rollout` looks ahead: it drives the tracker's own commands along their arcs, one control period
each, and returns the commands it would send on the way. A driver sends them behind its command
(`DriveCommand.then`), so when it is held up (two loaded cores at RTF 50 hold a control loop for
seconds of sim) the vehicle goes on along the plan instead of holding one arc and weaving.
"""

from __future__ import annotations

import bisect
import copy
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from modules.helm.errors import HelmError
from wire.drive import DriveStep

__all__ = ["TrackerConfig", "TrackCommand", "PathTracker", "TrackerError", "tracker_config_for", "Actuation", "predict_pose", "rollout",
           "Lookahead", "drive_steps"]


class TrackerError(HelmError, ValueError):
    """A plan is unusable (fewer than 2 poses, mismatched speeds, non-finite values)."""


class TrackerConfig(BaseModel):
    """Pure pursuit settings: lookahead [m] = clamp(base + gain·|v|), limits on curvature, speed, acceleration."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    lookahead_base: float = Field(1.5, gt=0.0, description="lookahead at standstill [m]")
    lookahead_gain: float = Field(0.8, ge=0.0, description="lookahead growth with speed [s]")
    lookahead_max: float = Field(8.0, gt=0.0, description="[m]")
    max_curvature: float = Field(1.0 / 7.0, gt=0.0, description="vehicle curvature limit [1/m] (Navlab: 1/7)")
    max_speed: float = Field(2.0, gt=0.0, description="vehicle speed limit [m/s]")
    max_accel: float = Field(0.5, gt=0.0, description="commanded speed rise per second [m/s²]")
    max_decel: float = Field(1.0, gt=0.0, description="braking used to stop at the plan's end [m/s²]")
    max_lateral_accel: float = Field(1.0, gt=0.0, description="[m/s²]")
    goal_tolerance: float = Field(0.15, gt=0.0, description="the plan is done this close to its end [m]")
    min_speed: float = Field(0.1, ge=0.0, description="creep speed while the end is still ahead [m/s]")
    search_window: int = Field(80, gt=0, description="poses searched ahead for the closest pose")
    turn_in_place_angle: float | None = Field(
        None, gt=0.0, description="skid steer: turn on the spot when the target is this far off the heading [rad]"
    )
    max_turn_rate: float = Field(0.5, gt=0.0, description="turn-in-place rate [rad/s]")
    speed_lag: float = Field(0.0, ge=0.0, description="drive's speed response time [s]: braking starts this much earlier")
    overshoot: float | None = Field(
        None, ge=0.0,
        description="how far [rad] past the lookahead point's bearing an arc may turn the vehicle before it lapses "
                    "(None: it holds to the lookahead point)",
    )


def tracker_config_for(vehicle: str) -> TrackerConfig:
    """Return the tracker preset for `vehicle` (Navlab: 7 m turning radius; Terregator: turns in place)."""
    if vehicle == "navlab":
        return TrackerConfig(max_curvature=1.0 / 7.0, max_speed=7.5, lookahead_base=3.0, lookahead_gain=1.0,
                             lookahead_max=10.0, max_accel=0.8, max_decel=1.5, speed_lag=0.4)
    if vehicle == "terregator":
        return TrackerConfig(max_curvature=2.0, max_speed=1.0, lookahead_base=1.0, lookahead_gain=0.8, max_accel=0.4,
                             speed_lag=0.3, turn_in_place_angle=math.radians(50.0), max_turn_rate=0.4)
    raise TrackerError(f"unknown vehicle {vehicle!r} (navlab or terregator)")


@dataclass(frozen=True)
class TrackCommand:
    """One control output: speed [m/s] (signed), curvature [1/m], cross-track error [m], remaining [m], done.

    `turn_rate` [rad/s] is set (with speed 0) when a skid-steer vehicle should turn on the spot.
    `horizon` [s] is how long the command stays good if no newer one follows: the time to reach the
    lookahead point on its arc (never past the plan's end), and with `TrackerConfig.overshoot` set, on a
    curved arc no longer than it takes to turn the heading by the point's bearing and the overshoot
    more (pure pursuit's arc turns by twice the bearing, so a late command held the whole way leaves
    the vehicle turned past the plan as far as it started off it: the weave), or to finish the turn on
    the spot;
    infinite for a stop.
    """

    speed: float
    curvature: float
    cross_track: float
    remaining: float
    done: bool
    turn_rate: float | None = None
    horizon: float = math.inf


class PathTracker:
    """Track the newest plan: call set_plan() when one arrives, command() every control tick."""

    def __init__(self, cfg: TrackerConfig = TrackerConfig()) -> None:
        """Start with no plan (commands are stops)."""
        self.cfg = cfg
        self._poses: np.ndarray | None = None
        self._speeds: np.ndarray | None = None
        self._s: np.ndarray | None = None
        self._a = self._d = self._ll = None
        self._idx = 0
        self._fresh = True
        self._last_speed = 0.0

    @property
    def has_plan(self) -> bool:
        """Return whether a plan is loaded."""
        return self._poses is not None

    def set_plan(self, poses: np.ndarray, speeds: np.ndarray) -> None:
        """Replace the plan: poses (N,3) [m, m, rad] in the local frame, speeds (N,) [m/s]."""
        poses = np.asarray(poses, dtype=np.float64)
        speeds = np.asarray(speeds, dtype=np.float64)
        if poses.ndim != 2 or poses.shape[1] != 3 or len(poses) < 2:
            raise TrackerError(f"plan needs at least 2 poses of (x, y, yaw), got shape {poses.shape}")
        if speeds.shape != (len(poses),):
            raise TrackerError(f"plan has {len(poses)} poses but {speeds.shape} speeds")
        if not (np.all(np.isfinite(poses)) and np.all(np.isfinite(speeds))):
            raise TrackerError("plan has non-finite values")
        self._poses = poses
        self._speeds = speeds
        self._s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
        # per segment, once: start (N-1, 2), direction (N-1, 2) [m], squared length (N-1,) [m²]
        self._a = np.ascontiguousarray(poses[:-1, :2])
        self._d = poses[1:, :2] - poses[:-1, :2]
        self._ll = np.maximum(np.einsum("ij,ij->i", self._d, self._d), 1e-12)
        # the same numbers as Python floats, for the scalar arithmetic of each command
        self._s_list: list[float] = self._s.tolist()
        self._xy_list: list[list[float]] = poses[:, :2].tolist()
        self._speed_list: list[float] = speeds.tolist()
        self._end = tuple(poses[-1].tolist())
        self._idx = 0
        self._fresh = True

    def clear(self) -> None:
        """Drop the plan (commands become stops)."""
        self._poses = self._speeds = self._s = self._a = self._d = self._ll = None

    def fork(self) -> "PathTracker":
        """Return a tracker on the same plan with its own progress and speed ramp (this one is left as it is)."""
        return copy.copy(self)  # the plan's arrays are replaced, never changed in place: sharing them is safe

    def _nearest(self, p: np.ndarray) -> tuple[int, float, float]:
        """Return (segment index, fraction along it, signed cross-track [m], left +) of the closest point."""
        n = len(self._poses)
        lo, hi = (0, n - 1) if self._fresh else (self._idx, min(n - 1, self._idx + self.cfg.search_window))
        a, d = self._a[lo:hi], self._d[lo:hi]
        t = np.minimum(np.maximum(np.einsum("ij,ij->i", p - a, d) / self._ll[lo:hi], 0.0), 1.0)
        c = a + t[:, None] * d
        dist = np.hypot(*(p - c).T)
        k = int(np.argmin(dist))
        cross = d[k, 0] * (p[1] - a[k, 1]) - d[k, 1] * (p[0] - a[k, 0])
        self._idx = lo + k
        self._fresh = False
        return lo + k, float(t[k]), float(math.copysign(dist[k], cross))

    def halt(self) -> None:
        """Forget the speed ramp: the vehicle was held at a stop, so the next command ramps up from rest."""
        self._last_speed = 0.0

    def command(self, pose: np.ndarray, dt: float) -> TrackCommand:
        """Return the drive command for local←vehicle `pose` (3,) after a control period `dt` [s]."""
        if self._poses is None:
            self._last_speed = 0.0
            return TrackCommand(0.0, 0.0, 0.0, 0.0, True)
        cfg = self.cfg
        pose = np.asarray(pose, dtype=np.float64).reshape(3)
        i, t, cross = self._nearest(pose[:2])
        px, py, pyaw = pose.tolist()
        sl = self._s_list
        s_here = sl[i] + t * (sl[i + 1] - sl[i])
        remaining = sl[-1] - s_here
        end = self._end
        # Past the end (projected beyond the last pose along its heading) counts as arrived.
        beyond = (px - end[0]) * math.cos(end[2]) + (py - end[1]) * math.sin(end[2])
        if remaining <= cfg.goal_tolerance or (i >= len(sl) - 2 and beyond >= 0.0):
            self._last_speed = 0.0
            return TrackCommand(0.0, 0.0, cross, max(0.0, remaining), True)
        speeds = self._speed_list
        plan_v = speeds[min(i + 1, len(speeds) - 1)]
        ahead = speeds[i : min(len(speeds), i + 8)]
        v_far = max(ahead, key=abs)  # the first of the largest magnitude
        v_ref = abs(v_far)  # 0 when every speed ahead is 0
        reverse = (plan_v if plan_v != 0.0 else v_far) < 0.0
        # Brake for the end, counting the distance covered while the drive responds (speed lag).
        brake_room = max(0.0, remaining - cfg.goal_tolerance - self._last_speed * cfg.speed_lag)
        v_ref = min(v_ref, cfg.max_speed, math.sqrt(2.0 * cfg.max_decel * brake_room))
        v_ref = max(v_ref, min(cfg.min_speed, remaining))
        v_cmd = min(v_ref, self._last_speed + cfg.max_accel * max(dt, 0.0))
        # Lookahead point: walk along the plan; past the end, extend along the final heading.
        ld = min(cfg.lookahead_max, cfg.lookahead_base + cfg.lookahead_gain * abs(v_cmd))
        s_goal = s_here + ld
        if s_goal <= sl[-1]:
            j = min(max(bisect.bisect_left(sl, s_goal) - 1, 0), len(sl) - 2)
            f = (s_goal - sl[j]) / max(sl[j + 1] - sl[j], 1e-12)
            (ax, ay), (bx, by) = self._xy_list[j], self._xy_list[j + 1]
            tx, ty = ax + f * (bx - ax), ay + f * (by - ay)
        else:
            extra = s_goal - sl[-1]
            tx, ty = end[0] + extra * math.cos(end[2]), end[1] + extra * math.sin(end[2])
        dx, dy = tx - px, ty - py
        c, s = math.cos(pyaw), math.sin(pyaw)
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        bearing = math.atan2(ly, lx if not reverse else -lx)
        if cfg.turn_in_place_angle is not None and abs(bearing) > cfg.turn_in_place_angle:
            self._last_speed = 0.0
            rate = math.copysign(cfg.max_turn_rate, ly if not reverse else -ly)
            # Turn until the target is within the turn-in-place angle again (then driving takes over).
            horizon = (abs(bearing) - cfg.turn_in_place_angle + 0.05) / cfg.max_turn_rate
            return TrackCommand(0.0, 0.0, cross, remaining, False, turn_rate=rate, horizon=max(horizon, 0.0))
        # yaw rate = v·kappa, so the same arc through the target serves forward and reverse driving.
        kappa = 2.0 * ly / max(lx * lx + ly * ly, 1e-9)
        kappa = max(-cfg.max_curvature, min(cfg.max_curvature, kappa))
        v_lat = math.sqrt(cfg.max_lateral_accel / max(abs(kappa), 1e-9))
        v_cmd = min(v_cmd, v_lat)
        self._last_speed = v_cmd
        # The arc leads to the lookahead point on the plan: good for that far, never past the plan's end.
        reach = min(ld, max(remaining - cfg.goal_tolerance, 0.0))
        horizon = reach / v_cmd if v_cmd > 1e-6 else 0.0
        turn_rate = v_cmd * abs(kappa)  # [rad/s]
        if cfg.overshoot is not None and turn_rate > 1e-9:
            horizon = min(horizon, (abs(bearing) + cfg.overshoot) / turn_rate)
        return TrackCommand(-v_cmd if reverse else v_cmd, kappa, cross, remaining, False, horizon=horizon)


@dataclass(frozen=True)
class Actuation:
    """What a driver sends for one control period: speed [m/s], curvature [1/m], turn rate [rad/s] (None: drive the arc)."""

    speed: float
    curvature: float
    turn_rate: float | None = None

    @property
    def moving(self) -> bool:
        """Return whether this moves the vehicle (drives or turns on the spot)."""
        return self.speed != 0.0 or (self.turn_rate is not None and self.turn_rate != 0.0)


def predict_pose(pose: np.ndarray, act: Actuation, dt: float) -> np.ndarray:
    """Return the pose (3,) [m, m, rad] reached from `pose` after `dt` [s] of `act`, exactly along its arc (no lag)."""
    x, y, yaw = (float(v) for v in pose)
    if act.turn_rate is not None:
        return np.array([x, y, yaw + act.turn_rate * dt])
    ds = act.speed * dt
    dyaw = act.curvature * ds
    if abs(dyaw) < 1e-9:
        return np.array([x + ds * math.cos(yaw), y + ds * math.sin(yaw), yaw])
    r = ds / dyaw
    return np.array([x + r * (math.sin(yaw + dyaw) - math.sin(yaw)), y - r * (math.cos(yaw + dyaw) - math.cos(yaw)), yaw + dyaw])


def rollout(tracker: PathTracker, pose: np.ndarray, first: Actuation, shape: Callable[[TrackCommand, float], Actuation],
            period: float, horizon: float) -> list[tuple[Actuation, float]]:
    """Return the (actuation, duration [s]) a driver would send after `first` over the next `horizon` [s] sim.

    From `pose` (local←vehicle) `first` is driven for one control `period` [s]; a fork of `tracker`
    is then asked at each pose reached, and `shape` turns its command into what the driver sends (its
    speed caps and ramp, which it must keep on copies). Stops at the plan's end or a stop; steps alike
    to within 1 mm/s and 1e-4 1/m are merged into one longer step. `tracker` itself is left as it is.
    """
    fork = tracker.fork()
    steps: list[tuple[Actuation, float]] = []
    act, p = first, np.asarray(pose, dtype=np.float64)
    for _ in range(max(0, int(round(horizon / period)))):
        p = predict_pose(p, act, period)
        cmd = fork.command(p, period)
        if cmd.done:
            break
        act = shape(cmd, period)
        if not act.moving:
            break
        if steps and _close(steps[-1][0], act, 1e-3, 1e-4, 1e-4):
            steps[-1] = (steps[-1][0], steps[-1][1] + period)
        else:
            steps.append((act, period))
    return steps


def _close(a: Actuation, b: Actuation, dv: float, dk: float, dw: float) -> bool:
    """Return whether `a` and `b` agree within `dv` [m/s], `dk` [1/m] and `dw` [rad/s] (and both turn on the spot or neither)."""
    if (a.turn_rate is None) != (b.turn_rate is None):
        return False
    if a.turn_rate is not None and abs(a.turn_rate - b.turn_rate) > dw:  # type: ignore[operator]
        return False
    return abs(a.speed - b.speed) <= dv and abs(a.curvature - b.curvature) <= dk


def drive_steps(ahead: list[tuple[Actuation, float]]) -> tuple[DriveStep, ...]:
    """Return the (actuation, duration [s]) of a look ahead as the steps a drive command carries behind it (`then`)."""
    return tuple(DriveStep(speed=a.speed, curvature=a.curvature, turn_rate=a.turn_rate, duration=d) for a, d in ahead)


class Lookahead:
    """The steps a driver sends behind each command (`rollout`), predicted afresh only when needed.

    A rollout costs some twenty tracker commands; a driver on time sends a command every `period`
    [s] sim and would throw each prediction away. So a prediction is kept and its remainder sent
    behind the next commands, and predicted again once it is `every` [s] sim old, for a new plan,
    or when the command in hand differs from what was predicted for now (the vehicle went its own way).
    Steps cover `horizon` [s] sim after the command when fresh, at least `horizon - every` later.
    """

    def __init__(self, period: float, horizon: float, every: float = 0.5) -> None:
        self.period, self.horizon, self.every = period, horizon, every
        self._plan: object = None
        self._t0 = -math.inf
        self._pred: list[tuple[Actuation, float, float]] = []  # (actuation, start, end) [s] sim
        self.predictions = 0  # rollouts made (for tests and the curious)

    def reset(self) -> None:
        """Forget the prediction (a stop, a nudge)."""
        self._pred = []
        self._plan = None

    def steps(self, now: float, tracker: PathTracker, pose: np.ndarray, first: Actuation,
              shape: Callable[[TrackCommand, float], Actuation]) -> list[tuple[Actuation, float]]:
        """Return the (actuation, duration [s]) to send behind `first`, sent at sim time `now` [s] from `pose`."""
        start = now + self.period
        if (tracker._poses is not self._plan or not now - self.every < self._t0 <= now
                or not self._on_prediction(now, first)):
            self._plan, self._t0 = tracker._poses, now
            self._pred, t = [], start
            for act, d in rollout(tracker, pose, first, shape, self.period, self.horizon):
                self._pred.append((act, t, t + d))
                t += d
            self.predictions += 1
        return [(act, e - max(b, start)) for act, b, e in self._pred if e - max(b, start) > 1e-6]

    def _on_prediction(self, now: float, first: Actuation) -> bool:
        """Return whether `first` is what the prediction has for `now` (within 5 cm/s, 0.05 1/m, 0.05 rad/s)."""
        for act, b, e in self._pred:
            if b - 1e-6 <= now < e:
                return _close(act, first, 0.05, 0.05, 0.05)
        return False
