"""A stereo camera pair (FIDO's, Navlab 1990 §4.3): two cameras side by side, rendered by the colour camera.

The pair is rectified by construction: both cameras have the same intrinsics and orientation (looking
ahead, pitched down like the colour camera) and the right one sits `baseline` [m] to the right of
the left one, along the left camera's optical x axis, so a point's images lie on the same row and
its disparity u_left − u_right = f·baseline / depth. Each image is the colour camera's render
(`camera.expose`) from its own projection centre, with the same weather, shadows, illumination
change and pixel noise. Frames: `vehicle` (x forward, y left, z up), `stereo_left` and
`stereo_right` (optical: x right, y down, z forward).

The paper gives the image size (512×512) and nothing else of the cameras. Our choices: a 0.5 m
baseline (about the 52 cm slider of Moravec's Cart, FIDO's ancestor), a 60° field of view, the pair
at the colour camera's height and pitch on each vehicle.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.scene import Scene
from vehicle_sim.sensors.camera import CameraConfig, CameraModel, camera_model, develop, expose
from vehicle_sim.sensors.extrinsics import Transform, extrinsics_for, vehicle_from_optical

__all__ = ["StereoConfig", "StereoMount", "StereoFrames", "stereo_mount_for", "stereo_model", "shoot_stereo"]


class StereoConfig(BaseModel):
    """The pair's cameras: square image side [px], horizontal field of view [deg], baseline [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    size: int = Field(512, ge=64, le=2048, multiple_of=64)  # the paper's 512×512
    hfov_deg: float = Field(60.0, gt=1, lt=150)
    baseline: float = Field(0.5, gt=0.0, le=5.0)


@dataclass(frozen=True)
class StereoMount:
    """Where the pair sits on one vehicle: the midpoint between the projection centres [m] (`vehicle`), pitch [deg]."""

    vehicle: str
    centre: tuple[float, float, float]
    pitch_deg: float
    baseline: float

    @property
    def vehicle_from_left(self) -> Transform:
        """Return `vehicle ← stereo_left`."""
        x, y, z = self.centre
        return vehicle_from_optical((x, y + 0.5 * self.baseline, z), self.pitch_deg)

    @property
    def vehicle_from_right(self) -> Transform:
        """Return `vehicle ← stereo_right`."""
        x, y, z = self.centre
        return vehicle_from_optical((x, y - 0.5 * self.baseline, z), self.pitch_deg)


def stereo_mount_for(vehicle: str, config: StereoConfig = StereoConfig()) -> StereoMount:
    """Return the pair's mounting on `vehicle`: centred under the colour camera's height and pitch; ValueError for an unknown vehicle."""
    ext = extrinsics_for(vehicle)
    x, _, z = ext.camera_position
    return StereoMount(vehicle, (float(x), 0.0, float(z)), float(ext.camera_pitch_deg), float(config.baseline))


@lru_cache(maxsize=8)
def stereo_model(config: StereoConfig, pitch_deg: float) -> CameraModel:
    """Return (cached) the geometry both cameras of the pair share (the colour camera's lighting and noise)."""
    cam = CameraConfig(width=config.size, height=config.size, hfov_deg=config.hfov_deg)
    return camera_model(cam, pitch_deg)


@dataclass(frozen=True)
class StereoFrames:
    """One stereo capture: `left`, `right` (size, size, 3) uint8 RGB; truth of the left image: `labels`
    (size, size) uint8 class indices into `worldfile.KINDS`, `depth` (size, size) float32 depth along its
    optical axis [m] (inf = sky, NaN = a depth edge inside the pixel)."""

    left: np.ndarray
    right: np.ndarray
    labels: np.ndarray
    depth: np.ndarray


def shoot_stereo(scene: Scene, world_from_vehicle: Transform, yaw: float, stamp: float, mount: StereoMount,
                 model: CameraModel, rng: np.random.Generator) -> StereoFrames:
    """Render the pair with the vehicle at `world_from_vehicle` (heading `yaw` [rad]) at sim time `stamp` [s]; noise
    from `rng`, the left image's first."""
    left_origin = world_from_vehicle.apply(mount.vehicle_from_left.t)
    right_origin = world_from_vehicle.apply(mount.vehicle_from_right.t)
    left = expose(scene, left_origin, yaw, stamp, model, depth=True)
    right = expose(scene, right_origin, yaw, stamp, model)
    assert left.depth is not None
    return StereoFrames(left=develop(left, model, rng).image, right=develop(right, model, rng).image,
                        labels=left.labels, depth=left.depth)
