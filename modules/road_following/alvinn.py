"""ALVINN, Autonomous Land Vehicle In a Neural Network (Navlab 1990 §2.2.3): the image straight to a steering arc.

Each frame the camera image is reduced to the net's retina and the net's steering bar is read as a
curvature. ALVINN knows nothing of roads; the one geometric fact it offers is the seed's road point:
its training views steer back to the road centre `lookahead` metres ahead, so the steering arc meets
the road centre there (`arc_road_point`). Observing such points over time gives the road's position
and shape to map-based reasoning.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from modules.road_following.alvinn_net import AlvinnNet, decode_steering
from modules.road_following.alvinn_training import arc_road_point, retina
from modules.road_following.camera import CameraGeometry
from modules.road_following.follower import RoadObservation, VehicleMotion

__all__ = ["Alvinn"]


class Alvinn:
    """ALVINN on one camera with a trained net (see module docstring)."""

    def __init__(self, camera: CameraGeometry, net: AlvinnNet, *, min_confidence: float = 0.5) -> None:
        """Drive with `net` on images of `camera`; below `min_confidence` a frame reports no road."""
        self.camera = camera
        self.net = net
        self.min_confidence = min_confidence

    @classmethod
    def from_file(cls, camera: CameraGeometry, path: str | Path) -> "Alvinn":
        """Load the net from an `.npz` weights file (AlvinnModelError if unusable)."""
        return cls(camera, AlvinnNet.load(path))

    def observe(self, image: np.ndarray, *, speed_mps: float = 0.0, stamp: float = 0.0,
                motion: VehicleMotion | None = None) -> RoadObservation:
        """Return the steering for `image` (H, W, 3) uint8 and the road point its arc implies (`vehicle`)."""
        t0 = time.perf_counter()
        self.camera.check_image(image)
        s = self.net.shape
        out = self.net.forward(retina(image, s.rows, s.cols)[None, :])
        curv, conf = decode_steering(out, s)
        k, c = float(curv[0]), float(conf[0])
        return RoadObservation(method="alvinn", stamp=stamp, found=c >= self.min_confidence, steering_curvature_per_m=k,
                               road_point=arc_road_point(k, s.lookahead_m), confidence=c,
                               ms_per_frame=(time.perf_counter() - t0) * 1e3)
