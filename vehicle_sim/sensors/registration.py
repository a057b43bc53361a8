"""Colored-range registration: project laser points into the camera (seed: Sidewalk §3.4.1).

Each laser pixel's 3-D point (vehicle frame) is moved into the camera frame with the known
extrinsics, projected with the intrinsics `K`, and the colour at that camera pixel is assigned to the
range pixel. Occlusion between the two viewpoints is not resolved (as in the original system).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehicle_sim.sensors.extrinsics import Transform

__all__ = ["ColoredRange", "project", "register"]


@dataclass(frozen=True)
class ColoredRange:
    """The colored-range image, laser image order: `colour` (rows, cols, 3) uint8 RGB; `uv` (rows, cols, 2)
    float32 camera pixel of each laser point (NaN where not projected); `valid` (rows, cols) bool."""

    colour: np.ndarray
    uv: np.ndarray
    valid: np.ndarray


def project(points_vehicle: np.ndarray, camera_from_vehicle: Transform, K: np.ndarray,
            size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Project vehicle-frame points (..., 3) [m] to camera pixels: (uv (..., 2) float64, inside (...) bool).

    `size` is (width, height) [px]; `inside` means in front of the camera and within the image.
    """
    p = np.asarray(points_vehicle, np.float64)
    pc = p @ camera_from_vehicle.R.T + camera_from_vehicle.t
    z = pc[..., 2]
    front = z > 1e-3
    zs = np.where(front, z, 1.0)
    u = K[0, 0] * pc[..., 0] / zs + K[0, 2]
    v = K[1, 1] * pc[..., 1] / zs + K[1, 2]
    w, h = size
    inside = front & (u >= -0.5) & (u <= w - 0.5) & (v >= -0.5) & (v <= h - 0.5) & np.isfinite(u) & np.isfinite(v)
    return np.stack([u, v], -1), inside


def register(points_vehicle: np.ndarray, valid: np.ndarray, image: np.ndarray,
             camera_from_vehicle: Transform, K: np.ndarray) -> ColoredRange:
    """Colour each laser point (rows, cols, 3) [m] (vehicle frame) from the camera `image` (h, w, 3) uint8."""
    h, w = image.shape[:2]
    uv, inside = project(np.nan_to_num(points_vehicle), camera_from_vehicle, K, (w, h))
    ok = inside & valid
    uv32 = np.where(ok[..., None], uv, -10.0).astype(np.float32)
    colour = cv2.remap(image, uv32[..., 0], uv32[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    colour[~ok] = 0
    return ColoredRange(colour=colour, uv=np.where(ok[..., None], uv, np.nan).astype(np.float32), valid=ok)
