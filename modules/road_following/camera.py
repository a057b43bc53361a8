"""The camera model the road followers use: a pinhole `K` and its mount `vehicle ← camera`, flat ground z = 0.

Built from the simulator's self-describing capture the way PERCEPTION builds its sensor frame
(`CameraGeometry.from_capture` reads `camera_K`, `T_vehicle_camera`, `camera_image`), so nothing here
imports the simulator. Frames: `vehicle` (x forward, y left, z up, origin on the ground), `camera`
(optical: x right, y down, z forward); pixel centres at integer (u, v), u right, v down.
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from modules.road_following.errors import CameraGeometryError

__all__ = ["CameraGeometry"]

_Row3 = tuple[float, float, float]
_Row4 = tuple[float, float, float, float]


class CameraGeometry(BaseModel):
    """A pinhole camera on the vehicle: image size [px], intrinsics `K` (3×3), mount `T_vehicle_camera` (4×4)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    width: int = Field(gt=0)
    height: int = Field(gt=0)
    K: tuple[_Row3, _Row3, _Row3]
    T_vehicle_camera: tuple[_Row4, _Row4, _Row4, _Row4]

    @model_validator(mode="after")
    def _sane(self) -> "CameraGeometry":
        k = np.asarray(self.K)
        if not (k[0, 0] > 0 and k[1, 1] > 0 and np.isfinite(k).all()):
            raise ValueError("K needs positive finite focal lengths")
        t = np.asarray(self.T_vehicle_camera)
        if not np.isfinite(t).all() or abs(abs(np.linalg.det(t[:3, :3])) - 1.0) > 1e-3:
            raise ValueError("T_vehicle_camera needs a rotation in its upper-left 3×3")
        if t[2, 3] <= 0.0:
            raise ValueError(f"the camera must be above the ground (z = {t[2, 3]:g} m)")
        return self

    @classmethod
    def from_capture(cls, obj: Any) -> "CameraGeometry":
        """Build from any object with the capture's names (`camera_K`, `T_vehicle_camera`, `camera_image`)."""
        try:
            img = obj.camera_image
            h, w = int(img.shape[0]), int(img.shape[1])
            return cls(width=w, height=h, K=tuple(map(tuple, np.asarray(obj.camera_K, float))),
                       T_vehicle_camera=tuple(map(tuple, np.asarray(obj.T_vehicle_camera, float))))
        except AttributeError as exc:
            raise CameraGeometryError(f"capture: {exc.name or exc} is missing (request the camera)") from None
        except ValueError as exc:
            raise CameraGeometryError(f"capture: camera calibration unusable: {exc}") from None

    def check_image(self, image: np.ndarray) -> np.ndarray:
        """Return `image` if it is (height, width, 3) uint8 for this camera; CameraGeometryError otherwise."""
        if not isinstance(image, np.ndarray) or image.shape != (self.height, self.width, 3) or image.dtype != np.uint8:
            got = (getattr(image, "shape", None), getattr(image, "dtype", None))
            raise CameraGeometryError(f"image: expected ({self.height}, {self.width}, 3) uint8, got shape {got[0]} dtype {got[1]}")
        return image

    def scaled(self, width: int, height: int) -> "CameraGeometry":
        """Return the same camera for an image resampled to width × height [px] (area averaging)."""
        sx, sy = width / self.width, height / self.height
        k = np.asarray(self.K, float).copy()
        k[0, 0] *= sx
        k[1, 1] *= sy
        k[0, 2] = (k[0, 2] + 0.5) * sx - 0.5
        k[1, 2] = (k[1, 2] + 0.5) * sy - 0.5
        return self.model_copy(update={"width": width, "height": height, "K": tuple(map(tuple, k))})

    # ---- arrays --------------------------------------------------------------------------

    @cached_property
    def k(self) -> np.ndarray:
        """Return K as a (3, 3) float64 array."""
        return np.asarray(self.K, np.float64)

    @cached_property
    def rotation(self) -> np.ndarray:
        """Return R of `vehicle ← camera`, (3, 3) float64."""
        return np.asarray(self.T_vehicle_camera, np.float64)[:3, :3]

    @cached_property
    def position(self) -> np.ndarray:
        """Return the camera centre in `vehicle` (3,) [m]."""
        return np.asarray(self.T_vehicle_camera, np.float64)[:3, 3]

    def rays(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Return the unit-free ray directions of pixels (u, v) in `vehicle` axes, (..., 3) float64."""
        k = self.k
        d = np.stack([(np.asarray(u, float) - k[0, 2]) / k[0, 0], (np.asarray(v, float) - k[1, 2]) / k[1, 1],
                      np.ones(np.shape(u))], axis=-1)
        return d @ self.rotation.T

    def ground_points(self, u: np.ndarray, v: np.ndarray, max_range: float = 300.0) -> np.ndarray:
        """Return where pixels (u, v) meet the ground z = 0, (..., 2) [m] in `vehicle`; NaN above the horizon or beyond `max_range`."""
        d = self.rays(u, v)
        c = self.position
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(d[..., 2] < -1e-9, -c[2] / d[..., 2], np.nan)
        xy = c[:2] + s[..., None] * d[..., :2]
        far = ~(np.hypot(xy[..., 0] - c[0], xy[..., 1] - c[1]) <= max_range)
        xy[far] = np.nan
        return xy

    def project(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return pixel (u, v) of `vehicle` points (..., 3) [m] and a mask of points in front of the camera."""
        p = (np.asarray(xyz, float) - self.position) @ self.rotation
        z = p[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = self.k[0, 0] * p[..., 0] / z + self.k[0, 2]
            v = self.k[1, 1] * p[..., 1] / z + self.k[1, 2]
        return u, v, z > 1e-6

    def project_ground(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return pixel (u, v) of ground points `xy` (..., 2) [m] in `vehicle` and the in-front mask."""
        xy = np.asarray(xy, float)
        return self.project(np.concatenate([xy, np.zeros(xy.shape[:-1] + (1,))], axis=-1))

    @cached_property
    def horizon_row(self) -> float:
        """Return the image row [px] of the horizon straight ahead (ground at infinity along +x)."""
        p = np.array([1.0, 0.0, 0.0]) @ self.rotation
        return float(self.k[1, 1] * p[1] / p[2] + self.k[1, 2])

    @cached_property
    def ground_grid(self) -> np.ndarray:
        """Return the ground point of every pixel, (height, width, 2) [m] in `vehicle` (NaN above the horizon)."""
        u, v = np.meshgrid(np.arange(self.width, dtype=float), np.arange(self.height, dtype=float))
        return self.ground_points(u, v)
