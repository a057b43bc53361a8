"""The FIDO OBSTACLE DETECTOR process: the OBSTACLE DETECTOR with FIDO's stereo in place of the laser (Navlab 1990 §4.3).

Each cycle it asks the simulator for a stereo pair (images never go through the blackboard), looks
up the vehicle pose in `local` at the pair's time, runs a FIDO step (`modules.fido.FidoObstacleWatch`:
the features tracked from the last step, the search guided by the dead-reckoned motion between the
two poses) and checks the newest local path plan's corridor for FIDO's obstacle features. It posts
one `obstacle_report` (frame `local`) per pair, as the laser's detector does, so the HELM stops for
it and the CAPTAIN counts it; each obstacle feature goes in as a small square with its height.
FIDO gives no landmark fixes.

  reads   local_path_plan (newest), poses local←vehicle
  asks    sidewalk/<ns>/sim/capture (stereo pair only)
  writes  obstacle_report
"""

from __future__ import annotations

import asyncio
import logging
import math

from codger.obstacles.detector import ObstacleDetector, ObstacleDetectorConfig, plan_in_vehicle
from modules.fido import FidoError, FidoObstacleWatch, FidoWatchConfig, StereoPair, StereoRig
from modules.vocabulary import ObstaclePolygon, ObstacleReport

__all__ = ["FidoObstacleDetector", "FEATURE_HALF_SIDE_M"]

log = logging.getLogger("codger.fido_obstacles")
#: each sighting that blocks the path is logged whatever SIDEWALK_LOG says: the run's log is where a stop is explained
log.setLevel(logging.INFO)

#: each obstacle feature is reported as a square this much [m] either side of it
FEATURE_HALF_SIDE_M = 0.1


class FidoObstacleDetector(ObstacleDetector):
    """Run the FIDO OBSTACLE DETECTOR on a module runtime `rt` (blackboard `rt.bb`, Zenoh link `rt.link`, clock `rt.clock`)."""

    cycle_errors = (*ObstacleDetector.cycle_errors, FidoError)

    def __init__(self, rt, cfg: ObstacleDetectorConfig = ObstacleDetectorConfig(), watch: FidoWatchConfig = FidoWatchConfig()) -> None:
        super().__init__(rt, cfg, ())
        self.watch = FidoObstacleWatch(watch)

    def capture_request(self) -> dict:
        """Return what a cycle asks the simulator's capture service for (the stereo pair alone)."""
        return {"laser": False, "camera": False, "stereo": True, "stereo_size": self.watch.cfg.stereo_size}

    async def cycle(self) -> ObstacleReport | None:
        """Run a FIDO step on one stereo pair, check the newest plan's corridor and post the report; None without a plan."""
        plan = self.plan
        if plan is None:
            return None
        cap = await self._capture()
        pose = await self._pose_at(cap.stamp)
        pair, rig = StereoPair.from_capture(cap), StereoRig.from_capture(cap)
        seen = await asyncio.to_thread(self.watch.step, pair, rig, pose)
        path = plan_in_vehicle(plan, pose, self.cfg.lookahead_m)
        d = self.watch.corridor_distance(seen, path, self.cfg.half_width)
        blocked = d <= self.cfg.lookahead_m
        c, s = math.cos(pose[2]), math.sin(pose[2])
        h = FEATURE_HALF_SIDE_M
        polys = []
        for x, y, z in seen.xyz:
            gx, gy = pose[0] + c * x - s * y, pose[1] + s * x + c * y
            polys.append(ObstaclePolygon(polygon=((gx - h, gy - h), (gx + h, gy - h), (gx + h, gy + h), (gx - h, gy + h)),
                                         height=max(0.0, float(z))))
        rep = ObstacleReport(blocked=blocked, distance_m=float(d) if blocked else 0.0, sensed_at=float(cap.stamp),
                             plan_seq=plan.seq, obstacles=tuple(polys))
        await self.rt.bb.post(rep, frame="local", geometry=None, stamp=float(cap.stamp))
        self.scans += 1
        self.blocked_scans += int(blocked)
        if blocked:
            log.info("fido: t=%.2f an obstacle feature %.1f m along the plan (%d obstacle features, %d new; %d features, %d tracked; %.0f ms)",
                     seen.stamp, d, len(seen.xyz), seen.new, seen.features, seen.tracked, seen.step_ms)
        return rep
