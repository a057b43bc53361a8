"""The road method a driving module uses, and one follower kept across its frames (both architectures).

`--road-method perception|scarf|yarf|alvinn`: `perception` is the colored-range segmentation of
PERCEPTION (the default of both architectures); the others are this package's followers. A
`CameraRoadFollower` builds its follower from the first capture's camera model (bootstrapping on
the lane the vehicle is told it drives in, the seed's one external input), hands it the odometry
between frames from the poses at capture, and starts afresh on `reset()` (a new road after an
intersection).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal, Optional

import numpy as np

from modules.road_following.alvinn import Alvinn
from modules.road_following.alvinn_net import AlvinnNet
from modules.road_following.camera import CameraGeometry
from modules.road_following.errors import AlvinnModelError
from modules.road_following.follower import RoadFollower, RoadObservation
from modules.road_following.road_seen import motion_between
from modules.road_following.scarf import Scarf, ScarfConfig
from modules.road_following.spine_fit import Spine
from modules.road_following.yarf import Yarf

__all__ = ["RoadMethod", "ROAD_METHODS", "FOLLOWER_METHODS", "load_alvinn_weights", "CameraRoadFollower"]

RoadMethod = Literal["perception", "scarf", "yarf", "alvinn"]
#: Every road method, the default first.
ROAD_METHODS: tuple[str, ...] = ("perception", "scarf", "yarf", "alvinn")
#: The methods that are a road follower of this package.
FOLLOWER_METHODS: tuple[str, ...] = ("scarf", "yarf", "alvinn")


def load_alvinn_weights(path: str | Path | None) -> AlvinnNet:
    """Return ALVINN's net from a weights file; AlvinnModelError naming the file when it is missing or unusable."""
    if path is None or str(path) == "":
        raise AlvinnModelError("ALVINN needs weights: make them with `sidewalk roadfollow dataset` and `sidewalk roadfollow train`, "
                               "then pass --alvinn-weights FILE")
    return AlvinnNet.load(path)


class CameraRoadFollower:
    """One follower of `method` kept across frames, built on the first frame's camera (see module docstring)."""

    def __init__(self, method: str, *, alvinn_net: Optional[AlvinnNet] = None, vehicle_offset_m: float = 0.0,
                 road_width_m: float = 6.0, max_jump_m: float = 0.8, max_rejects: int = 3) -> None:
        """Follow with `method` (scarf, yarf, alvinn); the vehicle starts `vehicle_offset_m` [m] left of the road centre (negative: right).

        The road cannot jump between frames: a SCARF/YARF road whose centre 4–12 m ahead lies more than
        `max_jump_m` [m] from the last one accepted (a driveway, a shadow taken for road) is reported as
        no road, unless `max_rejects` frames in a row say so (then the road did move).
        """
        if method not in FOLLOWER_METHODS:
            raise ValueError(f"road method {method!r} is not one of {', '.join(FOLLOWER_METHODS)}")
        if method == "alvinn" and alvinn_net is None:
            raise AlvinnModelError("ALVINN needs a trained net (--alvinn-weights FILE)")
        self.method = method
        self.net = alvinn_net
        self.vehicle_offset_m = vehicle_offset_m
        self.road_heading_rad = 0.0
        self.road_width_m = road_width_m
        self.max_jump_m, self.max_rejects = max_jump_m, max_rejects
        self._accepted: np.ndarray | None = None  # the last accepted road centre, (3, 2) [m] in the poses' fixed frame
        self._rejects = 0
        self.follower: RoadFollower | None = None
        self._camera: CameraGeometry | None = None
        self._last_pose: tuple[float, float, float] | None = None

    def reset(self, vehicle_offset_m: float | None = None, road_heading_rad: float = 0.0) -> None:
        """Forget the road: the next frame bootstraps afresh on a new prior (vehicle offset [m], road heading in `vehicle` [rad])."""
        if vehicle_offset_m is not None:
            self.vehicle_offset_m = vehicle_offset_m
        self.road_heading_rad = road_heading_rad
        self.follower, self._last_pose, self._accepted, self._rejects = None, None, None, 0

    def _build(self, camera: CameraGeometry) -> RoadFollower:
        if self.method == "scarf":
            return Scarf(camera, ScarfConfig(road_width_m=self.road_width_m), prior_lateral_m=-self.vehicle_offset_m,
                         prior_heading_rad=self.road_heading_rad)
        if self.method == "yarf":
            return Yarf(camera, prior=Spine(offset=-self.vehicle_offset_m / math.cos(self.road_heading_rad), slope=math.tan(self.road_heading_rad)))
        assert self.net is not None
        return Alvinn(camera, self.net)

    def observe(self, image: np.ndarray, camera: CameraGeometry, pose: tuple[float, float, float], *, stamp: float,
                speed_mps: float = 0.0) -> RoadObservation:
        """Return the road in `image`; `pose` (x, y [m], yaw [rad]) is the vehicle's at capture in any fixed frame (`local`)."""
        if self.follower is None or camera != self._camera:
            self.follower, self._camera, self._last_pose = self._build(camera), camera, None
        motion = None if self._last_pose is None else motion_between(self._last_pose, pose)
        self._last_pose = tuple(float(v) for v in pose)  # type: ignore[assignment]
        obs = self.follower.observe(image, speed_mps=speed_mps, stamp=stamp, motion=motion)
        return self._gate(obs, pose)

    def _gate(self, obs: RoadObservation, pose: tuple[float, float, float]) -> RoadObservation:
        """Return `obs`, or `obs` marked as no road when its centre jumped from the last accepted one (see `__init__`)."""
        if obs.method == "alvinn" or not obs.found or obs.lateral_offset_m is None:
            return obs
        xs = np.array([4.0, 8.0, 12.0])
        c, s = math.cos(pose[2]), math.sin(pose[2])
        ys = np.array([obs.centre_at(float(x)) for x in xs])
        centre = np.stack([pose[0] + c * xs - s * ys, pose[1] + s * xs + c * ys], axis=-1)
        if self._accepted is not None and self._rejects < self.max_rejects:
            a, b = self._accepted[0], self._accepted[-1]
            d = (b - a) / max(float(np.linalg.norm(b - a)), 1e-9)
            across = np.abs((centre - a) @ np.array([-d[1], d[0]]))
            if float(across.max()) > self.max_jump_m:
                self._rejects += 1
                return obs.model_copy(update={"found": False, "confidence": 0.0})
        self._accepted, self._rejects = centre, 0
        return obs
