"""The terrain module's core (Navlab 1990 §2.4, §2.5): a plan across the terrain map, cut to a look-ahead, in `local`.

EDDIE's terrain module keeps a `modules.terrain.TerrainMap` in `world` (fused from ERIM images at the
navigator's pose), plans from the vehicle to the mission's off-road goal with the cross-country
planner on its pyramid, and sends the first `lookahead_m` of the plan to the integrated controller
in the controller's `local` frame (which never jumps), with the stamp of the newest image used.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from eddie.messages.controller import PathCommand
from modules.terrain.cross_country_planner import CrossCountryPlan, CrossCountryPlanner, CrossCountrySettings
from modules.terrain.terrain_map import TerrainMap
from wire.se2 import transform_points, wrap_angle

__all__ = ["CrossCountryPathConfig", "TerrainPath", "terrain_path"]


class CrossCountryPathConfig(BaseModel):
    """The terrain module's look-ahead [m], speed [m/s] and the planner's settings."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    lookahead_m: float = Field(12.0, gt=0.0, description="the controller gets at most this much of each plan [m]")
    speed_mps: float = Field(1.0, gt=0.0, description="speed the path is driven at [m/s]")
    planner: CrossCountrySettings = CrossCountrySettings()


class TerrainPath(BaseModel):
    """A path for the controller: poses (x [m], y [m], yaw [rad]) in `local`, the plan's terrain queries, the newest image's stamp [s sim]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    poses: tuple[tuple[float, float, float], ...] = Field(min_length=2)
    speed_mps: float = Field(gt=0.0)
    sensed_at: float
    terrain_queries: int = Field(ge=0)
    reaches_goal: bool

    def command(self, client: str, priority: int) -> PathCommand:
        """Return the `immediate` path command of this path for `client` at `priority`."""
        return PathCommand(client=client, priority=priority, points=tuple((x, y) for x, y, _ in self.poses),
                           speed=self.speed_mps, sensed_at=self.sensed_at)


def _cut(plan: CrossCountryPlan, lookahead: float) -> tuple[np.ndarray, bool]:
    """Return the plan's poses (n, 3) up to `lookahead` [m] of driving, and whether they reach the plan's end."""
    steps = np.hypot(*np.diff(plan.poses[:, :2], axis=0).T)
    along = np.concatenate([[0.0], np.cumsum(steps)])
    n = int(np.searchsorted(along, lookahead, side="right"))
    n = max(n, 2)
    return plan.poses[:n], n >= len(plan.poses)


def terrain_path(terrain: TerrainMap, start_world: tuple[float, float, float], goal_world: tuple[float, float],
                 local_from_world: tuple[float, float, float], sensed_at: float,
                 cfg: CrossCountryPathConfig = CrossCountryPathConfig()) -> TerrainPath:
    """Plan from `start_world` (x, y [m], θ [rad]) to `goal_world` (x, y [m]) on `terrain` and return the path's head in `local`.

    Raises the planner's `TerrainPlanningError` (inadmissible start or goal, no admissible path).
    """
    planner = CrossCountryPlanner(terrain.pyramid, terrain.vehicle, cfg.planner)
    # the planner's configurations are the vehicle's reference point, the controller's poses its pose frame
    plan = planner.plan(terrain.vehicle.reference_of(*start_world), (float(goal_world[0]), float(goal_world[1]), 0.0))
    head, whole = _cut(plan, cfg.lookahead_m)
    head = terrain.vehicle.origin_of(head)
    lfw = np.asarray(local_from_world, np.float64)
    xy = transform_points(lfw, head[:, :2])
    yaw = wrap_angle(head[:, 2] + lfw[2])
    poses = tuple((float(x), float(y), float(t)) for (x, y), t in zip(xy, yaw))
    return TerrainPath(poses=poses, speed_mps=cfg.speed_mps, sensed_at=sensed_at, terrain_queries=plan.terrain_queries,
                       reaches_goal=whole)
