"""POSITION ESTIMATOR (seed: Sidewalk §2.3.3): the perceived vehicle position from dead reckoning and PERCEPTION's fixes.

Predicts with the HELM's moving vehicle position (`local←vehicle` on the blackboard), updates with
PERCEPTION's fixes (behind the fix gate of `modules.pilot.fix_gate`, as EDDIE's navigator) and the
OBSTACLE DETECTOR's laser landmark fixes (`landmark_fix`, position only, behind a χ² gate; Navlab 1990
§2.5.4) (`world` frame) through the Kalman filter of `modules.pilot.kalman`, and posts
the perceived vehicle position: the `world←local` correction and a `position_estimate` token.
Times are sim time [s].
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from blackboard import Pose2D
from blackboard.errors import BlackboardError
from modules.pilot.config import PilotConfig
from modules.pilot.fix_gate import FixGate
from modules.pilot.kalman import EstimatorError, FixRefused, LineFix, PointFix, PoseFilter
from modules.pilot.polyline import PathLine
from modules.vocabulary import LandmarkFix
from modules.vocabulary import LineFix as VLineFix
from modules.vocabulary import PerceptionResult, PositionEstimate, RouteSegmentDescription
from modules.vocabulary import PointFix as VPointFix
from modules.vocabulary import Pose as VPose
from wire.se2 import compose

__all__ = ["PositionEstimator", "Odometry", "filter_fix"]

log = logging.getLogger("codger.pilot")


@dataclass
class Odometry:
    """The moving vehicle position: `local←vehicle` (x [m], y [m], yaw [rad]) read at sim time `stamp` [s]."""

    stamp: float
    pose: np.ndarray


def filter_fix(fix: VPointFix | VLineFix) -> PointFix | LineFix:
    """Return PERCEPTION's fix (vocabulary, `world`) as the Kalman filter's measurement."""
    if isinstance(fix, VPointFix):
        return PointFix(pose=np.array([fix.pose.x, fix.pose.y, fix.pose.yaw]), cov=np.array(fix.covariance).reshape(3, 3))
    return LineFix(point=np.array(fix.point), angle=fix.direction, cross_var=max(fix.lateral_var, 1e-6),
                   yaw=fix.yaw, yaw_var=None if fix.yaw_var is None else max(fix.yaw_var, 1e-8))


class PositionEstimator:
    """Keep the world←vehicle estimate of one PILOT; read odometry from and post corrections to the blackboard."""

    def __init__(self, bb, clock, cfg: PilotConfig) -> None:
        """Hold the blackboard client `bb` and the sim clock; nothing starts until `start`."""
        self.bb = bb
        self.clock = clock
        self.cfg = cfg
        self.filter: PoseFilter | None = None
        self.odom: Odometry | None = None
        self.fixes = 0
        self.fix_gate = FixGate()
        self.landmark_fixes = 0
        self.landmark_refused = 0
        self._fixes_seen: set[tuple[str, float]] = set()
        self._last_correction = -math.inf

    @property
    def started(self) -> bool:
        """Return whether the estimator has a start pose."""
        return self.filter is not None

    @property
    def pose(self) -> np.ndarray:
        """Return the estimated world←vehicle pose (3,) [m, m, rad]."""
        return self.filter.pose

    @property
    def cov(self) -> np.ndarray:
        """Return the estimate's covariance (3, 3) [m², m², rad²]."""
        return self.filter.cov

    @property
    def distance_m(self) -> float:
        """Return the distance travelled since the start [m]."""
        return self.filter.distance_m

    def world_from_local(self) -> np.ndarray:
        """Return the perceived correction world←local (3,) [m, m, rad] at the current odometry."""
        return self.filter.world_from_local(self.odom.pose)

    def sigma_xy(self) -> float:
        """Return the largest position standard deviation of the estimate [m]."""
        return float(math.sqrt(max(np.linalg.eigvalsh(self.filter.cov[:2, :2]).max(), 0.0)))

    # -- odometry ------------------------------------------------------------------------------
    async def read_odometry(self) -> Odometry | None:
        """Return the newest `local←vehicle` pose, or None while there is none."""
        try:
            p = await self.bb.lookup_pose(parent="local", child="vehicle", stamp=None)
        except BlackboardError:
            return None
        return Odometry(stamp=self.clock.now(), pose=p.as_array())

    async def _wait_odometry(self) -> Odometry:
        while True:
            o = await self.read_odometry()
            if o is not None:
                return o
            await self.clock.sleep(self.cfg.tick_s)

    async def motion_since(self, stamp: float) -> np.ndarray:
        """Return the vehicle's motion from sim time `stamp` [s] to the current odometry (vehicle frame then)."""
        try:
            then = await self.bb.lookup_pose(parent="local", child="vehicle", stamp=stamp)
        except BlackboardError:
            return np.zeros(3)
        return PoseFilter.motion(then.as_array(), self.odom.pose)

    # -- estimation ----------------------------------------------------------------------------
    async def start(self, first_segment: RouteSegmentDescription | None) -> bool:
        """Start from the blackboard's world←local, the configured start, or the segment; False: none known yet."""
        self.odom = await self._wait_odometry()
        cfg = self.cfg
        start: np.ndarray | None = None
        how = ""
        try:
            # A correction left by an earlier PILOT of this run (restart): keep its perception fixes.
            # One stamped after the current sim time belongs to an earlier simulator run: ignore it.
            info = await self.bb.frames()
            edge = info.edge("world", "local")
            if edge is not None and edge.newest is not None and edge.newest <= self.clock.now() + 1.0:
                wl = await self.bb.lookup_pose(parent="world", child="local", stamp=None)
                start = compose(wl.as_array(), self.odom.pose)
                how = "previous world←local correction"
        except BlackboardError:
            pass
        # The local frame's origin is where the vehicle stood when odometry started: world←vehicle
        # now is world←local ∘ local←vehicle.
        if start is None and cfg.start_pose is not None:
            start = compose(np.array(cfg.start_pose, dtype=np.float64), self.odom.pose)
            how = "configured start pose"
        if start is None and first_segment is not None:
            path = PathLine.from_points(first_segment.centreline)
            p = path.point_at(0.0)
            start = compose(np.array([p[0], p[1], path.heading_at(0.0)]), self.odom.pose)
            how = "start of the first route segment"
        if start is None:
            return False  # wait for the first route segment to say where we are
        cov = np.diag([cfg.start_sigma_xy**2, cfg.start_sigma_xy**2, cfg.start_sigma_yaw**2])
        self.filter = PoseFilter(start, cov, cfg.odometry, gate=cfg.fix_gate)
        log.info("pilot: estimator starts at %s (%s)", np.round(start, 3).tolist(), how)
        await self.post(force=True, source="dead-reckoning")
        return True

    async def step(self) -> None:
        """Predict with the odometry increment since the last step."""
        o = await self.read_odometry()
        if o is None or self.filter is None or self.odom is None:
            return
        self.filter.predict(PoseFilter.motion(self.odom.pose, o.pose))
        self.odom = o

    async def apply_fix(self, res: PerceptionResult) -> bool:
        """Update with a perceived result's fix (once per unit and capture); return whether it was used."""
        fix = res.fix
        key = (res.unit_id, res.captured_at)
        if fix is None or self.filter is None or key in self._fixes_seen:
            return False
        self._fixes_seen.add(key)
        motion = await self.motion_since(res.captured_at)
        try:
            meas = filter_fix(fix)
            if isinstance(meas, PointFix):
                self.filter.update_point(meas, motion_since=motion)
            else:
                self.filter.update_line(meas, motion_since=motion)
        except FixRefused as exc:
            self.fix_gate.on_refused(self.filter)
            log.warning("pilot: perception fix for %s refused: %s (%d in a row)", res.unit_id, exc, self.fix_gate.refused_in_row)
            return False
        except EstimatorError as exc:
            log.warning("pilot: perception fix for %s ignored: %s", res.unit_id, exc)
            return False
        self.fix_gate.on_used()
        self.fixes += 1
        return True

    async def apply_landmark_fix(self, fix: LandmarkFix) -> bool:
        """Update with a laser landmark position fix behind the χ² gate; return whether it was used."""
        if self.filter is None:
            return False
        motion = await self.motion_since(fix.sensed_at)
        try:
            self.filter.update_position(np.array(fix.position), np.array(fix.covariance).reshape(2, 2), motion_since=motion,
                                        gate=self.cfg.landmark_gate)
        except EstimatorError as exc:
            self.landmark_refused += 1
            log.info("pilot: landmark fix from %s ignored: %s", ",".join(fix.landmark_ids), exc)
            return False
        self.landmark_fixes += 1
        return True

    async def post(self, *, force: bool = False, source: str = "dead-reckoning", unit_id: str | None = None) -> None:
        """Post world←local and the position estimate (at most once per correction period unless `force`)."""
        now = self.clock.now()
        if not force and now - self._last_correction < self.cfg.correction_period_s:
            return
        self._last_correction = now
        wl = self.world_from_local()
        await self.bb.post_pose(
            parent="world", child="local", pose=Pose2D(x=float(wl[0]), y=float(wl[1]), yaw=float(wl[2])), stamp=now, hold=None
        )
        p, c = self.filter.pose, self.filter.cov
        est = PositionEstimate(
            pose=VPose(x=p[0], y=p[1], yaw=p[2]),
            covariance=tuple(float(v) for v in (0.5 * (c + c.T)).reshape(-1)),
            source=source,
            unit_id=unit_id,
        )
        await self.bb.post(est, frame="world", geometry=None, stamp=now)
