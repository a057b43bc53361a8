"""The lane a step keeps to: a quarter of the road's width to the kept side of its centre line.

As the MAP NAVIGATOR plans "keep right" under CODGER (`modules.map_navigator.describe.lateral_offset`):
the route is the road's centre line, and a step kept to a side ends, and is driven, in that lane.
Frames: `world` [m].
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Point

__all__ = ["lane_goal", "lane_offset", "shift_into_lane"]


def lane_offset(keep: str | None, width_m: float) -> float:
    """Return the lane's offset [m] left (+) of the road centre for `keep` (right, left; anything else: 0)."""
    return {"right": -width_m / 4.0, "left": width_m / 4.0}.get(keep or "", 0.0)


def lane_goal(map_data, line, goal: tuple[float, float], keep: str | None) -> tuple[float, float] | None:
    """Return `goal` moved a quarter of the nearest path's width to the kept side of the route's last direction (None: no side)."""
    if keep not in ("right", "left") or len(line) < 2 or not map_data.world.edges:
        return None
    p = Point(goal)
    width = min(map_data.world.edges, key=lambda e: LineString(e.coords).distance(p)).width
    (ax, ay), (bx, by) = line[-2], line[-1]
    yaw = math.atan2(by - ay, bx - ax)
    off = lane_offset(keep, width)
    return goal[0] - off * math.sin(yaw), goal[1] + off * math.cos(yaw)


def shift_into_lane(route: np.ndarray, offset_m: float) -> np.ndarray:
    """Return the polyline `route` (N, 2) [m] moved `offset_m` [m] to the left (+) of its direction at each vertex."""
    pts = np.asarray(route, dtype=np.float64)
    if offset_m == 0.0 or len(pts) < 2:
        return pts.copy()
    seg = np.diff(pts, axis=0)
    seg /= np.maximum(np.linalg.norm(seg, axis=1, keepdims=True), 1e-9)
    tang = np.vstack([seg[:1], seg[:-1] + seg[1:], seg[-1:]])  # a vertex: the mean of its segments' directions
    tang /= np.maximum(np.linalg.norm(tang, axis=1, keepdims=True), 1e-9)
    normal = np.column_stack([-tang[:, 1], tang[:, 0]])
    return pts + offset_m * normal
