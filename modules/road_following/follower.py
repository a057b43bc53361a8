"""What every road follower reports per frame (Navlab 1990 §2.2): the road in `vehicle`, or a steering arc.

SCARF and YARF report where the road is and how it runs (the road centre's lateral offset at the
vehicle origin and its heading, YARF also its curvature); ALVINN reports a steering curvature and
the point where its arc meets the road centre (§2.2.3). Each report carries a confidence in [0, 1]
and the wall time the frame took. `VehicleMotion` is the odometry between two frames, which the
followers use to carry their state into the new vehicle frame.
"""

from __future__ import annotations

import math
from typing import Literal, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["Branch", "FeatureReport", "RoadObservation", "VehicleMotion", "RoadFollower", "FeatureStatus"]

_FROZEN = ConfigDict(frozen=True, extra="forbid")

#: A tracker's local verdict on its window (Navlab 1990 §2.2.2 "Error Detection and Recovery").
FeatureStatus = Literal["found", "missing", "clipped", "illumination_shift", "too_large"]


class Branch(BaseModel):
    """A branch road SCARF found leaving the main road: where along it [m], at what angle [rad], how probable."""

    model_config = _FROZEN

    along_m: float
    angle_rad: float
    probability: float = Field(ge=0.0, le=1.0)


class FeatureReport(BaseModel):
    """One YARF tracker's result in one window: feature kind, its offset from the spine [m], verdict, point in `vehicle` [m]."""

    model_config = _FROZEN

    kind: Literal["yellow", "white"]
    offset_m: float
    lookahead_m: float
    status: FeatureStatus
    point: tuple[float, float] | None = None
    score: float = 0.0


class RoadObservation(BaseModel):
    """One frame's road: centre offset [m] and heading [rad] in `vehicle` (or a steering arc), confidence, time.

    `lateral_offset_m`: the road centre line's y at x = 0 (+ left); `heading_rad`: its direction
    relative to the vehicle's x axis (+ counter-clockwise); `road_curvature_per_m` [1/m] (+ left);
    `steering_curvature_per_m` [1/m] the arc to drive (ALVINN); `road_point` a point of the road
    centre in `vehicle` [m] (ALVINN: where its arc meets the road centre). `found` is False when the
    follower saw no road this frame (then the geometry fields may hold its prediction).
    """

    model_config = _FROZEN

    method: Literal["scarf", "yarf", "alvinn"]
    stamp: float = 0.0
    found: bool
    lateral_offset_m: float | None = None
    heading_rad: float | None = None
    road_curvature_per_m: float | None = None
    steering_curvature_per_m: float | None = None
    road_point: tuple[float, float] | None = None
    confidence: float = Field(ge=0.0, le=1.0)
    ms_per_frame: float = Field(ge=0.0)
    branches: tuple[Branch, ...] = ()
    features: tuple[FeatureReport, ...] = ()

    def centre_at(self, x: float) -> float | None:
        """Return the road centre's lateral position y [m] at distance x [m] ahead in `vehicle`, when known."""
        if self.lateral_offset_m is None or self.heading_rad is None:
            return None
        c = self.road_curvature_per_m or 0.0
        return self.lateral_offset_m + math.tan(self.heading_rad) * x + 0.5 * c * x * x


class VehicleMotion(BaseModel):
    """The vehicle's displacement between two frames: the new pose in the old `vehicle` frame (dx, dy [m], dyaw [rad])."""

    model_config = _FROZEN

    dx: float = 0.0
    dy: float = 0.0
    dyaw: float = 0.0

    @classmethod
    def straight(cls, speed_mps: float, dt_s: float) -> "VehicleMotion":
        """Return the motion of driving straight at `speed_mps` [m/s] for `dt_s` [s] (no odometry to hand)."""
        return cls(dx=max(0.0, speed_mps) * max(0.0, dt_s))

    def to_new(self, xy: np.ndarray) -> np.ndarray:
        """Map points (..., 2) [m] from the old `vehicle` frame into the new one."""
        c, s = math.cos(self.dyaw), math.sin(self.dyaw)
        d = np.asarray(xy, float) - (self.dx, self.dy)
        return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)


class RoadFollower(Protocol):
    """A road follower: one camera frame in, one `RoadObservation` out."""

    def observe(self, image: np.ndarray, *, speed_mps: float = 0.0, stamp: float = 0.0,
                motion: VehicleMotion | None = None) -> RoadObservation:
        """Return the road seen in `image` (H, W, 3) uint8 at sim time `stamp` [s]; `motion` since the last frame."""
        ...
