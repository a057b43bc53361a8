"""The vehicle's full 3-D pose as the robot estimates it: position, heading, and the roll and pitch its INS reads.

Navlab 1990 §2.3.3: consecutive images are registered "in x, y, roll, pitch, and yaw" from the INS,
and in z by the mean difference of the maps. Frames: `world` (x east, y north, z up) [m];
`vehicle` (x forward, y left, z up; origin on the ground under the rear-axle centre); the rotation
world ← vehicle is Rz(yaw)·Ry(pitch)·Rx(roll) (REP-103: roll > 0 left side up, pitch > 0 nose down).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wire.se2 import wrap_angle

__all__ = ["VehiclePose"]


@dataclass(frozen=True)
class VehiclePose:
    """A pose estimate of the vehicle in `world`: x, y, z [m], roll, pitch, yaw [rad]."""

    x: float
    y: float
    z: float
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0

    def rotation(self) -> np.ndarray:
        """Return world ← vehicle, (3, 3) float64."""
        cr, sr = math.cos(self.roll), math.sin(self.roll)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        cy, sy = math.cos(self.yaw), math.sin(self.yaw)
        rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
        ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
        rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
        return rz @ ry @ rx

    def world_from_vehicle(self) -> np.ndarray:
        """Return world ← vehicle as a 4×4 homogeneous matrix, float64."""
        T = np.eye(4)
        T[:3, :3] = self.rotation()
        T[:3, 3] = (self.x, self.y, self.z)
        return T

    def vehicle_from_world(self) -> np.ndarray:
        """Return vehicle ← world, the inverse of `world_from_vehicle`, 4×4 float64."""
        T = np.eye(4)
        R = self.rotation()
        T[:3, :3] = R.T
        T[:3, 3] = -R.T @ np.array([self.x, self.y, self.z])
        return T

    def moved(self, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0, dyaw: float = 0.0,
              pivot: tuple[float, float] | None = None) -> "VehiclePose":
        """Return this pose turned by `dyaw` [rad] about `pivot` (x, y) [m] (default: itself), then shifted by (dx, dy, dz) [m]."""
        px, py = (self.x, self.y) if pivot is None else pivot
        c, s = math.cos(dyaw), math.sin(dyaw)
        x = px + c * (self.x - px) - s * (self.y - py) + dx
        y = py + s * (self.x - px) + c * (self.y - py) + dy
        yaw = wrap_angle(self.yaw + dyaw)
        return VehiclePose(x, y, self.z + dz, self.roll, self.pitch, yaw)
