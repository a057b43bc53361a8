"""The lane a step keeps to: a quarter of the road's width to the kept side of its centre line.

As the MAP NAVIGATOR plans "keep right" under CODGER (`modules.map_navigator.describe.lateral_offset`):
the route is the road's centre line, and a step kept to a side ends, and is driven, in that lane. A
step's goal is in the lane of the road the route arrives on, on the kept side of the route's last
direction: EDDIE's own reading of the mission on the robot's map. Frames: `world` [m].
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["KERB_MARGIN_M", "lane_goal", "goal_lane_offset", "lane_point", "lane_offset", "kept_lane_offset", "goal_kept_offset",
           "shift_into_lane"]

#: kept between the vehicle's obstacle clearance and the road's edge when a step keeps to a side [m]
KERB_MARGIN_M = 0.5


def lane_offset(keep: str | None, width_m: float) -> float:
    """Return the lane's offset [m] left (+) of the road centre for `keep` (right, left; anything else: 0)."""
    return {"right": -width_m / 4.0, "left": width_m / 4.0}.get(keep or "", 0.0)


def kept_lane_offset(keep: str | None, width_m: float, keep_offset_m: float, edge_keep_m: float) -> float:
    """Return the offset [m] left (+) of the road centre a kept side is driven at.

    A quarter of the road's width `width_m` [m] (the lane), at most the PILOT's `keep_offset_m` [m] for the
    vehicle (1.5 m for the Navlab, 0.3 m for the Terregator on walks with benches beside them), and
    leaving `edge_keep_m` [m] inside the road's edge; 0 where that does not fit.
    """
    off = lane_offset(keep, width_m)
    return math.copysign(max(0.0, min(abs(off), keep_offset_m, width_m / 2.0 - edge_keep_m)), off)


def goal_kept_offset(lane_offset_m: float | None, edge_keep_m: float) -> float:
    """Return the offset [m] left (+) of the route a step kept to a side ends at (0: no side).

    Its goal's lane (`lane_offset_m`: a quarter of the width of the road the route arrives on,
    `goal_lane_offset`) as far as the road there leaves `edge_keep_m` [m] inside its edge: a 6 m plaza
    gives 1.4 m for the Terregator, a 3 m walk nothing (a 2 m vehicle fits only on its centre).
    """
    if not lane_offset_m:
        return 0.0
    room = 2.0 * abs(lane_offset_m) - edge_keep_m  # half the width, less what is kept inside the edge
    return math.copysign(max(0.0, min(abs(lane_offset_m), room)), lane_offset_m)


def goal_lane_offset(route, keep: str | None) -> float | None:
    """Return the offset [m] left (+) of the route's last direction of the lane `keep` at the end of `route` (the MAP
    NAVIGATOR's `Route` on the robot's map): a quarter of the width of the road its last leg drives (None: no side)."""
    if keep not in ("right", "left") or not route.legs:
        return None
    return lane_offset(keep, route.legs[-1].width)


def lane_point(goal: tuple[float, float], offset_m: float, yaw: float) -> tuple[float, float]:
    """Return `goal` moved `offset_m` [m] to the left (+) of direction `yaw` [rad] (`world`)."""
    return goal[0] - offset_m * math.sin(yaw), goal[1] + offset_m * math.cos(yaw)


def lane_goal(route, goal: tuple[float, float], keep: str | None) -> tuple[float, float] | None:
    """Return `goal` moved into the lane `keep` of `route`'s last direction (`goal_lane_offset`; None: no side)."""
    line = route.polyline()
    off = goal_lane_offset(route, keep) if len(line) >= 2 else None
    if off is None:
        return None
    (ax, ay), (bx, by) = line[-2], line[-1]
    return lane_point(goal, off, math.atan2(by - ay, bx - ax))


def shift_into_lane(route: np.ndarray, offset_m: float | np.ndarray) -> np.ndarray:
    """Return the polyline `route` (N, 2) [m] moved `offset_m` [m] (one for all, or (N,) one per vertex) to the left (+) of its direction at each vertex."""
    pts = np.asarray(route, dtype=np.float64)
    off = np.asarray(offset_m, dtype=np.float64)
    if not np.any(off) or len(pts) < 2:
        return pts.copy()
    if off.ndim:
        off = off[:, None]
    seg = np.diff(pts, axis=0)
    seg /= np.maximum(np.linalg.norm(seg, axis=1, keepdims=True), 1e-9)
    tang = np.vstack([seg[:1], seg[:-1] + seg[1:], seg[-1:]])  # a vertex: the mean of its segments' directions
    tang /= np.maximum(np.linalg.norm(tang, axis=1, keepdims=True), 1e-9)
    normal = np.column_stack([-tang[:, 1], tang[:, 0]])
    return pts + off * normal
