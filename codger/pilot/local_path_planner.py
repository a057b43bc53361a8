"""LOCAL PATH PLANNER (seed: Sidewalk §2.3.3): the local path plan from the vehicle through the driving units.

Plans from the vehicle's estimated pose through the goals of all resolved driving units to the far
edge of the newest, inside the DRIVING UNIT NAVIGATOR's region (the OMPL search of
`planner.LocalPathPlanner`, run off the event loop), gives the path a speed profile
(`speed_profile`), and posts it for the HELM as a `local_path_plan` in the `local` frame
(local←world = (world←local)⁻¹ at the current odometry). Times are sim time [s].
"""

from __future__ import annotations

import asyncio
import functools
import math

import numpy as np

from blackboard import Polyline as BbPolyline
from modules.pilot.config import PilotConfig
from modules.pilot.planner import LocalPathPlanner, PlannedPath
from modules.pilot.speed_profile import speed_profile
from modules.vocabulary import LocalPathPlan, PlanPose, RouteSegmentDescription
from wire.se2 import inverse, transform_points, wrap_angle

__all__ = ["LocalPathPlanning"]


class LocalPathPlanning:
    """The PILOT's LOCAL PATH PLANNER: search a path in `world`, post it with speeds in `local`."""

    def __init__(self, bb, cfg: PilotConfig) -> None:
        """Hold the blackboard client; seed the search from `cfg.seed`."""
        self.bb = bb
        self.cfg = cfg
        self.search = LocalPathPlanner(cfg.planner, seed=cfg.seed)
        self.seq = 0
        self.last_plan_t = -math.inf

    async def plan(self, start: np.ndarray, goals, region, *, relax_goal: bool = False, reverse: bool = True) -> PlannedPath:
        """Return a path from `start` (3,) through `goals` inside `region` (world); raise PlanningError.

        `relax_goal`: the last goal need not be met exactly (the vehicle does not stop there), so a
        forward path to it moved sideways is preferred to reversing; `reverse`: fall back on a
        reversing path when no forward one is found.
        """
        return await asyncio.to_thread(functools.partial(self.search.plan, relax_goal=relax_goal, reverse=reverse), start, goals, region)

    async def plan_reversing(self, start: np.ndarray, goals, region) -> PlannedPath:
        """Return a path from `start` through `goals` inside `region` (world) that may reverse; raise PlanningError."""
        return await asyncio.to_thread(self.search.plan_reversing, start, goals, region)

    async def post(self, seg: RouteSegmentDescription, path: PlannedPath, world_local: np.ndarray, unit_ids: tuple[str, ...],
                   speed_limit: float, stop_at_end: bool, now: float, *, sensed_at: float | None = None) -> LocalPathPlan:
        """Post `path` (world) for the HELM in `local` given world←local (3,), with speeds ≤ `speed_limit` [m/s].

        `sensed_at` [s sim]: the newest capture among the perceived units the plan was built on.
        """
        # Only a segment that must stop at its exit ends in a stop; otherwise the HELM brakes to the
        # plan's end by itself unless the next plan (or the next segment's) arrives first.
        v = speed_profile(path.s, path.curvature, path.direction, speed_limit, stop_at_end=stop_at_end, cfg=self.cfg.speed)
        local_world = inverse(world_local)
        xy = transform_points(local_world, path.poses[:, :2])
        yaw = path.poses[:, 2] + local_world[2]
        self.seq += 1
        poses = tuple(
            PlanPose.from_pose2d((px, py, wrap_angle(a)), speed=float(sp))
            for (px, py), a, sp in zip(xy, yaw, v)
        )
        plan = LocalPathPlan(seq=self.seq, segment_id=seg.segment_id, unit_ids=unit_ids, frame="local", poses=poses,
                             stop_at_end=stop_at_end, sensed_at=sensed_at)
        await self.bb.post(plan, frame="local", geometry=BbPolyline(points=tuple((p.x, p.y) for p in poses)), stamp=now)
        self.last_plan_t = now
        return plan
