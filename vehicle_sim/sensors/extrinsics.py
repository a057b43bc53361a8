"""Known mounting poses of the sensors on the vehicle, and rigid transforms between frames.

Frames (REP-103 axes): `world` (x east, y north, z up) [m]; `vehicle` (origin on the ground under the
rear-axle centre, x forward, y left, z up; on flat worlds the vehicle stays level: pose (x, y, yaw)
with z the ground height under the origin; on rough ground it also rolls and pitches with the wheel
plane, `vehicle_sim.ground_contact`); `laser` (origin at the scanner, axes parallel to `vehicle`: the
scanner's azimuth axis is vertical and its elevation window is set by `LaserConfig.tilt_deg`);
`camera` (optical frame: origin at the projection centre, x right, y down, z along the optical axis,
pitched down by `pitch_deg`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

__all__ = [
    "Transform",
    "Extrinsics",
    "VEHICLES",
    "extrinsics_for",
    "world_from_vehicle",
    "vehicle_from_world",
]

VEHICLES: tuple[str, ...] = ("navlab", "terregator")


@dataclass(frozen=True)
class Transform:
    """A rigid transform `dst ← src`: p_dst = R @ p_src + t; R (3, 3) float64, t (3,) float64 [m]."""

    R: np.ndarray
    t: np.ndarray

    @staticmethod
    def from_matrix(T: np.ndarray) -> "Transform":
        """Return the transform of a 4×4 homogeneous matrix."""
        T = np.asarray(T, np.float64)
        return Transform(T[:3, :3].copy(), T[:3, 3].copy())

    @property
    def matrix(self) -> np.ndarray:
        """Return the 4×4 homogeneous matrix, float64."""
        T = np.eye(4)
        T[:3, :3] = self.R
        T[:3, 3] = self.t
        return T

    def inverse(self) -> "Transform":
        """Return the inverse transform `src ← dst`."""
        return Transform(self.R.T.copy(), -self.R.T @ self.t)

    def compose(self, other: "Transform") -> "Transform":
        """Return self ∘ other (`a ← c` from self `a ← b` and other `b ← c`)."""
        return Transform(self.R @ other.R, self.R @ other.t + self.t)

    def apply(self, p: np.ndarray) -> np.ndarray:
        """Map points (..., 3) [m] from the source frame to the destination frame (float64)."""
        return np.asarray(p, np.float64) @ self.R.T + self.t


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


#: vehicle ← optical axes for a camera looking along vehicle +x (x right = -y_v, y down = -z_v, z = x_v)
_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def world_from_vehicle(x: float, y: float, yaw: float, z: float = 0.0, roll: float = 0.0, pitch: float = 0.0) -> Transform:
    """Return `world ← vehicle` at (x, y) [m], heading `yaw` [rad], ground height z [m], roll and pitch [rad].

    R = Rz(yaw)·Ry(pitch)·Rx(roll) (REP-103: roll > 0 left side up, pitch > 0 nose down); level by default.
    """
    if roll == 0.0 and pitch == 0.0:
        return Transform(_rot_z(yaw), np.array([x, y, z], np.float64))
    return Transform(_rot_z(yaw) @ _rot_y(pitch) @ _rot_x(roll), np.array([x, y, z], np.float64))


def vehicle_from_world(x: float, y: float, yaw: float, z: float = 0.0, roll: float = 0.0, pitch: float = 0.0) -> Transform:
    """Return `vehicle ← world`, the inverse of `world_from_vehicle`."""
    return world_from_vehicle(x, y, yaw, z, roll, pitch).inverse()


@dataclass(frozen=True)
class Extrinsics:
    """Mounting of the scanner and camera on one vehicle: positions [m] in `vehicle`, camera pitch [deg]."""

    vehicle: str
    laser_position: tuple[float, float, float]
    camera_position: tuple[float, float, float]
    camera_pitch_deg: float

    @property
    def vehicle_from_laser(self) -> Transform:
        """Return `vehicle ← laser` (axes parallel, offset only)."""
        return Transform(np.eye(3), np.asarray(self.laser_position, np.float64))

    @property
    def laser_from_vehicle(self) -> Transform:
        """Return `laser ← vehicle`, the inverse of `vehicle_from_laser`."""
        return self.vehicle_from_laser.inverse()

    @property
    def vehicle_from_camera(self) -> Transform:
        """Return `vehicle ← camera` (optical frame, pitched down by `camera_pitch_deg`)."""
        R = _rot_y(math.radians(self.camera_pitch_deg)) @ _OPTICAL
        return Transform(R, np.asarray(self.camera_position, np.float64))

    @property
    def camera_from_vehicle(self) -> Transform:
        """Return `camera ← vehicle`, the inverse of `vehicle_from_camera`."""
        return self.vehicle_from_camera.inverse()

    @property
    def camera_from_laser(self) -> Transform:
        """Return `camera ← laser` (the registration transform)."""
        return self.camera_from_vehicle.compose(self.vehicle_from_laser)


_MOUNTS: dict[str, Extrinsics] = {
    # Navlab: scanner on the cab roof, colour camera above it, looking ahead and down.
    "navlab": Extrinsics("navlab", laser_position=(1.6, 0.0, 2.3), camera_position=(1.5, 0.1, 2.5), camera_pitch_deg=12.0),
    # Terregator: lower, smaller; scanner and camera on the front mast.
    "terregator": Extrinsics("terregator", laser_position=(0.7, 0.0, 1.6), camera_position=(0.6, 0.1, 1.85), camera_pitch_deg=14.0),
}


def extrinsics_for(vehicle: Literal["navlab", "terregator"] | str) -> Extrinsics:
    """Return the known sensor mounting for `vehicle` ("navlab" or "terregator"); ValueError otherwise."""
    try:
        return _MOUNTS[vehicle]
    except KeyError:
        raise ValueError(f"unknown vehicle {vehicle!r}; expected one of {list(VEHICLES)}") from None
