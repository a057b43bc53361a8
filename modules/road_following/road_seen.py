"""The road a follower saw, as geometry a planner can use: the line to drive and the road region, in `vehicle`.

SCARF and YARF report the road centre (offset, heading, curvature at the vehicle); the line to
drive is that centre moved `lane_offset_m` to its left (negative: right, a keep-right lane) and the
road region the centre widened by the road's half width. ALVINN reports only a steering arc
(§2.2.3: it steers directly): the line to drive is the arc itself, the region a corridor along it.
All points are in the `vehicle` frame of the capture (x forward, y left) [m]; the caller moves them
into its own frame with the pose at the capture.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry

from modules.road_following.errors import RoadFollowingError
from modules.road_following.follower import RoadObservation, VehicleMotion
from modules.road_following.spine_fit import Spine
from wire.se2 import between_tuple

__all__ = ["NoRoadSeen", "steering_arc", "drive_line", "road_region", "motion_between", "cross_section"]


class NoRoadSeen(RoadFollowingError):
    """The observation holds no road to drive along (the follower found none, or reported no geometry)."""


def steering_arc(curvature_per_m: float, length_m: float, step_m: float = 0.5) -> np.ndarray:
    """Return points (N, 2) [m] in `vehicle` along the arc of `curvature_per_m` [1/m] (+ left) from the origin for `length_m` [m]."""
    s = np.append(np.arange(0.0, length_m, step_m), length_m)
    k = float(curvature_per_m)
    if abs(k) < 1e-9:
        return np.stack([s, np.zeros_like(s)], axis=-1)
    return np.stack([np.sin(k * s) / k, (1.0 - np.cos(k * s)) / k], axis=-1)


def _centre_spine(obs: RoadObservation) -> Spine:
    if not obs.found or obs.lateral_offset_m is None or obs.heading_rad is None:
        raise NoRoadSeen(f"{obs.method}: no road in this frame (confidence {obs.confidence:.2f})")
    return Spine(offset=obs.lateral_offset_m, slope=math.tan(obs.heading_rad), curvature=obs.road_curvature_per_m or 0.0)


def _offset_line(spine: Spine, xs: np.ndarray, offset_m: float) -> np.ndarray:
    """Return the points of the curve `offset_m` [m] to the left of the spine (along its normal), at the spine's xs."""
    y = spine.lateral(xs)
    dy = spine.curvature * xs + spine.slope
    n = np.stack([-dy, np.ones_like(xs)], axis=-1) / np.sqrt(1.0 + dy * dy)[:, None]
    return np.stack([xs, y], axis=-1) + offset_m * n


def drive_line(obs: RoadObservation, *, lane_offset_m: float = 0.0, start_m: float = 0.0, length_m: float = 12.0,
               step_m: float = 0.5) -> np.ndarray:
    """Return the line to drive (N, 2) [m] in `vehicle`: the road centre moved `lane_offset_m` [m] left, x from `start_m` to `length_m`.

    ALVINN: the steering arc from the vehicle for `length_m` (the lane is in its training). Raise
    NoRoadSeen when the observation holds no road.
    """
    if obs.method == "alvinn":
        if not obs.found or obs.steering_curvature_per_m is None:
            raise NoRoadSeen(f"alvinn: no steering this frame (confidence {obs.confidence:.2f})")
        return steering_arc(obs.steering_curvature_per_m, length_m, step_m)
    xs = np.append(np.arange(start_m, length_m, step_m), length_m)
    return _offset_line(_centre_spine(obs), xs, lane_offset_m)


def road_region(obs: RoadObservation, *, half_width_m: float, near_m: float = 1.0, far_m: float = 20.0,
                step_m: float = 1.0) -> Polygon:
    """Return the road seen as a polygon in `vehicle` [m]: centre ± `half_width_m` from `near_m` to `far_m` ahead.

    ALVINN: a corridor of `half_width_m` about its arc. Raise NoRoadSeen when the observation holds no road.
    """
    xs = np.append(np.arange(near_m, far_m, step_m), far_m)
    if obs.method == "alvinn":
        if not obs.found or obs.steering_curvature_per_m is None:
            raise NoRoadSeen(f"alvinn: no steering this frame (confidence {obs.confidence:.2f})")
        arc = steering_arc(obs.steering_curvature_per_m, far_m, step_m)
        arc = arc[np.hypot(arc[:, 0], arc[:, 1]) >= near_m - 1e-9]
        d = np.gradient(arc, axis=0)
        n = np.stack([-d[:, 1], d[:, 0]], axis=-1) / np.maximum(np.linalg.norm(d, axis=1), 1e-12)[:, None]
        left, right = arc + half_width_m * n, arc - half_width_m * n
    else:
        spine = _centre_spine(obs)
        left, right = _offset_line(spine, xs, half_width_m), _offset_line(spine, xs, -half_width_m)
    poly = Polygon(np.vstack([right, left[::-1]]))
    return poly if poly.is_valid else poly.buffer(0)


def motion_between(before: tuple[float, float, float], after: tuple[float, float, float]) -> VehicleMotion:
    """Return the `VehicleMotion` from pose `before` to pose `after` (both x, y [m], yaw [rad] in one fixed frame)."""
    dx, dy, dyaw = between_tuple(before, after)
    return VehicleMotion(dx=dx, dy=dy, dyaw=dyaw)


def cross_section(road: BaseGeometry, pose: tuple[float, float, float], reach_m: float = 20.0) -> tuple[float, float] | None:
    """Return (the vehicle's offset left of the road centre [m], the road's width [m]) across a map road polygon at `pose`.

    The road is cut by the line through the vehicle square to its heading (`pose` and `road` in one
    frame, `world`); the piece holding the vehicle (else the nearest) is the road's cross-section.
    None when the cut misses the road.
    """
    x, y, yaw = pose
    n = np.array([-math.sin(yaw), math.cos(yaw)])
    cut = LineString([(x - reach_m * n[0], y - reach_m * n[1]), (x + reach_m * n[0], y + reach_m * n[1])]).intersection(road)
    parts = [g for g in getattr(cut, "geoms", [cut]) if g.geom_type == "LineString" and not g.is_empty]
    if not parts:
        return None
    me = Point(x, y)
    piece = min(parts, key=lambda g: g.distance(me))
    ends = np.asarray(piece.coords, float)[[0, -1]]
    side = (ends - (x, y)) @ n  # signed positions of the two edges across the road [m], + left
    return float(-(side[0] + side[1]) / 2.0), float(abs(side[1] - side[0]))
