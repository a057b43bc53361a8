"""Obstacle stop's core: is something standing in the vehicle's path, and how far ahead?

Seed: Navlab 1990 §2.5 — fast obstacle detection stops the vehicle through the controller (a
trigger starts and stops it). It reads the laser range image as PERCEPTION does
(`modules.perception.colored_range_image`: unwrapped range, points in `vehicle`) and counts the
returns that stand above the ground inside the corridor the vehicle will sweep.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.perception.image import ColoredRangeImage

__all__ = ["ObstacleStopConfig", "ObstacleReport", "obstacle_ahead"]


class ObstacleStopConfig(BaseModel):
    """The corridor checked ahead of the vehicle (`vehicle` frame, x forward, y left) and the evidence needed."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    stop_distance_m: float = Field(4.0, gt=0.0, description="look this far ahead of the vehicle origin [m]")
    near_m: float = Field(1.0, ge=0.0, description="ignore returns closer than this (the vehicle itself, its sensor mast) [m]")
    half_width_m: float = Field(1.2, gt=0.0, description="half the swept width [m]")
    min_height_m: float = Field(0.25, gt=0.0, description="a return this high above the ground is an obstacle [m]")
    max_height_m: float = Field(2.5, gt=0.0, description="returns above this clear the vehicle (branches) [m]")
    min_points: int = Field(6, ge=1, description="this many obstacle returns make an obstacle (noise and mixed points do not)")


class ObstacleReport(BaseModel):
    """What one range image shows: `blocked`, the nearest obstacle return ahead [m] (None: none), how many returns."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    blocked: bool
    distance_m: float | None = None
    points: int = 0
    stamp: float = 0.0


def obstacle_ahead(img: ColoredRangeImage, cfg: ObstacleStopConfig = ObstacleStopConfig()) -> ObstacleReport:
    """Return whether enough laser returns stand in the corridor ahead (`vehicle` frame, flat ground z = 0)."""
    xyz = img.xyz.reshape(-1, 3).astype(np.float64)
    ok = np.isfinite(img.range_m.reshape(-1)) & np.all(np.isfinite(xyz), axis=1)
    x, y, z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    hit = ok & (x >= cfg.near_m) & (x <= cfg.stop_distance_m) & (np.abs(y) <= cfg.half_width_m) \
        & (z >= cfg.min_height_m) & (z <= cfg.max_height_m)
    n = int(hit.sum())
    nearest = float(x[hit].min()) if n else None
    return ObstacleReport(blocked=n >= cfg.min_points, distance_m=nearest, points=n, stamp=float(img.stamp))
