"""The OBSTACLE DETECTOR process (seed: Navlab 1990 §2.3.2, the fast mode for emergency stop).

Each cycle it asks the simulator's scanner for a laser image (images never go through the
blackboard), looks up the vehicle pose in `local` at the scan's time, takes the newest local path
plan, and checks the plan's corridor for anything standing `min_height` above the ground
(`modules.perception.obstacles.path_clear_distance`); it also finds every obstacle of the scan as a
polygon with a height. It posts one `obstacle_report` (frame `local`) per scan.

Given the robot's map (`landmarks`), the small obstacles of a scan (trees, posts, mailboxes) are
landmark observations (`modules.perception.landmarks`): put in `world` at the PILOT's perceived
position (its newest `world←local` ∘ `local←vehicle` at the scan), paired with the map's landmarks
inside a Mahalanobis gate, and the vehicle position they agree on is posted as a `landmark_fix`
(at most one per `landmark_period_s`) for the PILOT's POSITION ESTIMATOR (Navlab 1990 §2.5.4).

  reads   local_path_plan (newest), poses local←vehicle, world←local
  asks    sidewalk/<ns>/sim/capture (laser only)
  writes  obstacle_report, landmark_fix
"""

from __future__ import annotations

import asyncio
import logging
import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from blackboard import Spec
from blackboard.errors import BlackboardError
from codger.laser_capture import LASER_ALONE, capture
from modules.perception.landmarks import LandmarkConfig, MapLandmark, landmark_fix, landmark_observations, match_landmarks
from modules.perception.obstacles import LaserScan, ObstacleConfig, detect_obstacles, path_clear_distance, path_in_vehicle
from modules.vocabulary import LandmarkFix, LocalPathPlan, ObstaclePolygon, ObstacleReport
from wire.se2 import compose
from wire.capture import CaptureDecodeError, CaptureResult

__all__ = ["ObstacleDetectorConfig", "ObstacleDetector"]

log = logging.getLogger("codger.obstacles")


class ObstacleDetectorConfig(BaseModel):
    """Detector settings: cycle [s] sim, corridor half-width [m], look-ahead [m], capture timeout [s] wall."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    period_s: float = Field(0.1, gt=0.0)
    half_width: float = Field(1.5, gt=0.0)  # Navlab half width 1.05 m plus a margin [m]
    lookahead_m: float = Field(20.0, gt=0.0)  # one ambiguity interval [m]
    capture_timeout_s: float = Field(5.0, gt=0.0)
    pose_wait_s: float = Field(1.0, ge=0.0)
    detection: ObstacleConfig = ObstacleConfig()
    landmark_period_s: float = Field(1.0, gt=0.0)  # at most one landmark_fix per this much sim time [s]
    prior_sigma_m: float = Field(1.0, gt=0.0)  # σ of the perceived position the matching gate allows for [m]
    landmark: LandmarkConfig = LandmarkConfig()


def plan_in_vehicle(plan: LocalPathPlan, pose: tuple[float, float, float], lookahead: float) -> np.ndarray:
    """Return the plan ahead of the vehicle, (K, 2) [m] in the `vehicle` frame, starting at the vehicle origin."""
    return path_in_vehicle(np.array([(q.x, q.y) for q in plan.poses], np.float64), pose, lookahead)


class ObstacleDetector:
    """Run the OBSTACLE DETECTOR on a module runtime `rt` (blackboard `rt.bb`, Zenoh link `rt.link`, clock `rt.clock`)."""

    #: the failures of a cycle that are logged and left behind (the next cycle tries again)
    cycle_errors: tuple[type[BaseException], ...] = (TimeoutError, CaptureDecodeError, BlackboardError, RuntimeError)

    def __init__(self, rt, cfg: ObstacleDetectorConfig = ObstacleDetectorConfig(),
                 landmarks: tuple[MapLandmark, ...] | list[MapLandmark] = ()) -> None:
        self.rt = rt
        self.cfg = cfg
        self.landmarks = tuple(landmarks)
        self.plan: LocalPathPlan | None = None
        self.scans = 0
        self.blocked_scans = 0
        self.landmark_fixes = 0
        self._last_fix = -math.inf

    async def _plans(self) -> None:
        async for ev in self.rt.bb.monitor(Spec(type="local_path_plan")):
            if ev.kind == "new" and (self.plan is None or ev.token.attrs.seq >= self.plan.seq):
                self.plan = ev.token.attrs

    def capture_request(self) -> dict:
        """Return what a cycle asks the simulator's capture service for (the laser alone)."""
        return dict(LASER_ALONE)

    async def _capture(self) -> CaptureResult:
        return await capture(self.rt, self.capture_request(), self.cfg.capture_timeout_s)

    async def _pose_at(self, stamp: float) -> tuple[float, float, float]:
        deadline = self.rt.clock.now() + self.cfg.pose_wait_s
        while True:
            try:
                p = await self.rt.bb.lookup_pose(parent="local", child="vehicle", stamp=stamp)
                return p.as_tuple()
            except BlackboardError:
                if self.rt.clock.now() >= deadline:
                    raise
                await self.rt.clock.sleep(0.05)

    async def landmark_fix(self, obstacles, pose_local: tuple[float, float, float], stamp: float) -> LandmarkFix | None:
        """Match a scan's small obstacles (`vehicle`) to the map's landmarks at the perceived pose; post and return the fix."""
        if not self.landmarks or stamp - self._last_fix < self.cfg.landmark_period_s:
            return None
        obs = landmark_observations(obstacles, self.cfg.landmark)
        if not obs:
            return None
        try:
            wl = await self.rt.bb.lookup_pose(parent="world", child="local", stamp=None)
        except BlackboardError:
            return None  # no perceived position yet
        prior = compose(wl.as_array(), np.asarray(pose_local, np.float64))
        near = [m for m in self.landmarks if math.hypot(m.x - prior[0], m.y - prior[1]) <= self.cfg.landmark.max_range + 5.0]
        matches = match_landmarks(obs, near, (float(prior[0]), float(prior[1]), float(prior[2])),
                                  pose_cov=np.eye(2) * self.cfg.prior_sigma_m ** 2, cfg=self.cfg.landmark)
        fix = landmark_fix(matches)
        if fix is None:
            return None
        cov = np.asarray(fix.cov, np.float64)
        cov = 0.5 * (cov + cov.T)
        tok = LandmarkFix(sensed_at=float(stamp), position=(float(prior[0] + fix.dx), float(prior[1] + fix.dy)),
                          covariance=tuple(float(v) for v in cov.reshape(-1)), prior=(float(prior[0]), float(prior[1])),
                          landmark_ids=tuple(m.landmark_id for m in matches))
        await self.rt.bb.post(tok, frame="world", geometry=None, stamp=float(stamp))
        self._last_fix = stamp
        self.landmark_fixes += 1
        return tok

    async def cycle(self) -> ObstacleReport | None:
        """Check one scan against the newest plan and post the report (and a landmark fix); None when there is no plan yet.

        Without a plan only the landmarks are matched (and only when there is a map).
        """
        plan = self.plan
        if plan is None and not self.landmarks:
            return None
        cap = await self._capture()
        pose = await self._pose_at(cap.stamp)
        scan = LaserScan.from_capture(cap)
        found = detect_obstacles(scan, self.cfg.detection)
        await self.landmark_fix(found, pose, float(cap.stamp))
        if plan is None:
            return None
        path = plan_in_vehicle(plan, pose, self.cfg.lookahead_m)
        d = path_clear_distance(scan, path, self.cfg.half_width, self.cfg.detection)
        blocked = d <= self.cfg.lookahead_m
        c, s = math.cos(pose[2]), math.sin(pose[2])
        polys = []
        for o in found:
            if len(o.polygon) < 3:
                continue
            ring = tuple((pose[0] + c * x - s * y, pose[1] + s * x + c * y) for x, y in o.polygon)
            polys.append(ObstaclePolygon(polygon=ring, height=max(0.0, o.height)))
        rep = ObstacleReport(blocked=blocked, distance_m=float(d) if blocked else 0.0, sensed_at=float(cap.stamp),
                             plan_seq=plan.seq, obstacles=tuple(polys))
        await self.rt.bb.post(rep, frame="local", geometry=None, stamp=float(cap.stamp))
        self.scans += 1
        self.blocked_scans += int(blocked)
        return rep

    async def run(self) -> None:
        """Check scans until the runtime stops."""
        await self.rt.clock.wait_running()
        plans = asyncio.ensure_future(self._plans())
        try:
            toks = await self.rt.bb.retrieve(Spec(type="local_path_plan", newest=True))
            if toks:
                self.plan = toks[0].attrs
        except BlackboardError as exc:
            log.warning("obstacles: cannot read the newest plan: %s", exc)
        self.rt.ready()
        try:
            while not self.rt.stopping:
                try:
                    await self.cycle()
                except self.cycle_errors as exc:
                    log.warning("obstacles: cycle failed: %s", exc)
                await self.rt.clock.sleep(self.cfg.period_s)
        finally:
            plans.cancel()
