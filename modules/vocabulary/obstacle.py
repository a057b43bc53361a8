"""Obstacle vocabulary: what the OBSTACLE DETECTOR saw on the laser along the planned path (seed: Navlab 1990 §2.3.2).

The detector posts one `obstacle_report` per laser scan: whether something stands in the corridor of
the local path plan, how far along the plan, and the obstacles of the scan as polygons with heights
(frame `local`, at the scan's time). The HELM stops for a blocking report and drives on once a newer
report says the path is clear.
"""

from __future__ import annotations

from typing import Literal

from modules.vocabulary._base import Frozen, NonNeg, Ring, finite, token_type

__all__ = ["ObstaclePolygon", "ObstacleReport"]


class ObstaclePolygon(Frozen):
    """One obstacle: a convex `polygon` [(x, y)] [m] in the report's frame, its `height` above the ground [m]."""

    polygon: Ring
    height: NonNeg


@token_type("obstacle_report")
class ObstacleReport(Frozen):
    """One laser scan checked against the local path plan: `blocked` when an obstacle stands in the
    plan's corridor, `distance_m` along the plan from the vehicle to it [m] (0 when clear),
    `sensed_at` [s] sim time of the scan, `plan_seq` the plan it was checked against."""

    blocked: bool
    distance_m: NonNeg = 0.0
    sensed_at: finite
    plan_seq: int = -1
    obstacles: tuple[ObstaclePolygon, ...] = ()
    frame: Literal["local"] = "local"
