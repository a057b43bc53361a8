"""Obstacle stop's core: is something standing on the controller's path, and how far along it?

Seed: Navlab 1990 §2.5 — fast obstacle detection stops the vehicle through the controller (a
trigger starts and stops it). The algorithm is the OBSTACLE DETECTOR's fast mode, as a library
(`modules.perception.obstacles`): the laser points into `vehicle`, unwrapped over the ground, and
only the corridor along the path looked at; a point standing `min_height` above the corridor's
ground is an obstacle point. The path is the one the controller tracks (its `path` stream, in
`local`), moved into `vehicle` by the controller's pose at the capture.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.perception.obstacles import LaserScan, ObstacleConfig, path_clear_distance, path_in_vehicle

__all__ = ["ObstacleStopConfig", "ObstacleReport", "obstacle_ahead", "remaining_m"]


class ObstacleStopConfig(BaseModel):
    """The corridor checked along the path (`vehicle` frame) and the evidence needed."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    # 15 m: at 3 m/s a frame a few seconds old (capture and detection on a loaded machine) plus braking still stops short
    stop_distance_m: float = Field(15.0, gt=0.0, description="stop for an obstacle this near along the path [m]")
    half_width_m: float = Field(1.5, gt=0.0, description="half the swept corridor [m] (the OBSTACLE DETECTOR's)")
    min_points: int = Field(3, ge=1, description="this many obstacle points make an obstacle (noise and mixed points do not)")
    end_margin_m: float = Field(1.5, ge=0.0, description="looked at past the commanded path's end (the vehicle's front and its stop) [m]")
    detection: ObstacleConfig = ObstacleConfig()


class ObstacleReport(BaseModel):
    """What one range image shows: `blocked`, the first obstacle point along the path [m] (None: clear)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    blocked: bool
    distance_m: float | None = None
    stamp: float = 0.0


def remaining_m(path_local: np.ndarray, pose_local: tuple[float, float, float]) -> float:
    """Return the length [m] of `path_local` (N, 2) [m, `local`] left ahead of the vehicle at `pose_local`.

    From the vehicle to the path point nearest it, then along the path to its end.
    """
    p = np.asarray(path_local, np.float64).reshape(-1, 2)
    if len(p) == 0:
        return 0.0
    here = np.array(pose_local[:2], np.float64)
    i = int(np.argmin(np.linalg.norm(p - here, axis=1)))
    rest = np.vstack([here, p[i:]])
    return float(np.linalg.norm(np.diff(rest, axis=0), axis=1).sum())


def obstacle_ahead(scan: LaserScan, cfg: ObstacleStopConfig = ObstacleStopConfig(), *,
                   path_local: np.ndarray | None = None, pose_local: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> ObstacleReport:
    """Return whether an obstacle stands on the path within `stop_distance_m`.

    `path_local` (N, 2) [m] is the path in `local` and `pose_local` the vehicle's pose there at the
    scan; without a path the corridor runs straight ahead.
    """
    path = path_in_vehicle(np.empty((0, 2)) if path_local is None else path_local, pose_local, cfg.stop_distance_m)
    d = path_clear_distance(scan, path, cfg.half_width_m, cfg.detection, min_points=cfg.min_points)
    # The controller stops at its path's end: an obstacle past it (a building behind the mission's goal)
    # is not in the way.
    reach = cfg.stop_distance_m if path_local is None else min(cfg.stop_distance_m, remaining_m(path_local, pose_local) + cfg.end_margin_m)
    blocked = math.isfinite(d) and d <= reach
    return ObstacleReport(blocked=blocked, distance_m=float(d) if math.isfinite(d) else None, stamp=float(scan.stamp))
