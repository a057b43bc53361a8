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

__all__ = ["ObstacleStopConfig", "ObstacleReport", "obstacle_ahead"]


class ObstacleStopConfig(BaseModel):
    """The corridor checked along the path (`vehicle` frame) and the evidence needed."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    # 15 m: at 3 m/s a frame a few seconds old (capture and detection on a loaded machine) plus braking still stops short
    stop_distance_m: float = Field(15.0, gt=0.0, description="stop for an obstacle this near along the path [m]")
    half_width_m: float = Field(1.5, gt=0.0, description="half the swept corridor [m] (the OBSTACLE DETECTOR's)")
    min_points: int = Field(3, ge=1, description="this many obstacle points make an obstacle (noise and mixed points do not)")
    detection: ObstacleConfig = ObstacleConfig()


class ObstacleReport(BaseModel):
    """What one range image shows: `blocked`, the first obstacle point along the path [m] (None: clear)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    blocked: bool
    distance_m: float | None = None
    stamp: float = 0.0


def obstacle_ahead(scan: LaserScan, cfg: ObstacleStopConfig = ObstacleStopConfig(), *,
                   path_local: np.ndarray | None = None, pose_local: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> ObstacleReport:
    """Return whether an obstacle stands on the path within `stop_distance_m`.

    `path_local` (N, 2) [m] is the path in `local` and `pose_local` the vehicle's pose there at the
    scan; without a path the corridor runs straight ahead.
    """
    path = path_in_vehicle(np.empty((0, 2)) if path_local is None else path_local, pose_local, cfg.stop_distance_m)
    d = path_clear_distance(scan, path, cfg.half_width_m, cfg.detection, min_points=cfg.min_points)
    blocked = math.isfinite(d) and d <= cfg.stop_distance_m
    return ObstacleReport(blocked=blocked, distance_m=float(d) if math.isfinite(d) else None, stamp=float(scan.stamp))
