"""The stereo pair FIDO sees through: the rectified rig's geometry and one pair of grey images.

Built from the simulator's self-describing capture (`stereo_left`, `stereo_right`, `stereo_K`,
`T_vehicle_stereo_left`, `T_vehicle_stereo_right`), so nothing here imports the simulator. Frames:
`vehicle` (x forward, y left, z up, origin on the ground), `left` (the left camera's optical frame:
x right, y down, z forward); the right camera sits `baseline` [m] along the left one's +x with the
same orientation (a rectified pair: a point's images share a row). Pixel centres at integer (u, v).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from modules.fido.errors import StereoGeometryError

__all__ = ["StereoRig", "StereoPair", "grey"]

#: The rectification tolerance: rotations equal and the baseline along x to this [rad or m/m].
_RECTIFIED = 1e-6


@dataclass(frozen=True)
class StereoRig:
    """A rectified pair: `K` (3, 3) float64 shared intrinsics, `baseline` [m], `T_vehicle_left` (4, 4) float64
    `vehicle ← left`, image `width` and `height` [px]."""

    K: np.ndarray
    baseline: float
    T_vehicle_left: np.ndarray
    width: int
    height: int

    @property
    def focal(self) -> float:
        """Return the focal length [px]."""
        return float(self.K[0, 0])

    def project(self, xyz: np.ndarray, camera: str = "left") -> tuple[np.ndarray, np.ndarray]:
        """Return the pixels (N, 2) float64 of `vehicle` points (N, 3) [m] in the `left` or `right` image, and (N,) bool:
        in front of the camera and inside the image."""
        p = np.asarray(xyz, np.float64).reshape(-1, 3)
        R, t = self.T_vehicle_left[:3, :3], self.T_vehicle_left[:3, 3]
        c = (p - t) @ R
        if camera == "right":
            c[:, 0] -= self.baseline
        elif camera != "left":
            raise StereoGeometryError(f"stereo rig: camera must be 'left' or 'right', not {camera!r}")
        z = c[:, 2]
        front = z > 1e-3
        zs = np.where(front, z, 1.0)
        uv = np.stack([self.focal * c[:, 0] / zs + self.K[0, 2], self.focal * c[:, 1] / zs + self.K[1, 2]], 1)
        inside = front & (uv[:, 0] >= 0) & (uv[:, 0] <= self.width - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= self.height - 1)
        return uv, inside

    @classmethod
    def from_capture(cls, obj: Any) -> "StereoRig":
        """Build from any object with the capture's stereo fields; `StereoGeometryError` if missing or not rectified."""
        try:
            K = np.asarray(obj.stereo_K, np.float64)
            tl = np.asarray(obj.T_vehicle_stereo_left, np.float64)
            tr = np.asarray(obj.T_vehicle_stereo_right, np.float64)
            h, w = obj.stereo_left.shape[:2]
        except (AttributeError, TypeError, ValueError):
            raise StereoGeometryError("stereo capture: the stereo images and calibration are missing (ask for stereo=True)") from None
        if K.shape != (3, 3) or tl.shape != (4, 4) or tr.shape != (4, 4):
            raise StereoGeometryError(f"stereo capture: K {K.shape}, T_vehicle_stereo_left {tl.shape}, right {tr.shape}: "
                                      "expected (3, 3), (4, 4), (4, 4)")
        if not (np.isfinite(K).all() and np.isfinite(tl).all() and np.isfinite(tr).all()) or K[0, 0] <= 0:
            raise StereoGeometryError("stereo capture: the calibration has a non-finite value or a focal length ≤ 0")
        if abs(K[0, 0] - K[1, 1]) > 1e-6 * K[0, 0] or abs(K[0, 1]) > 1e-9:
            raise StereoGeometryError("stereo capture: FIDO needs square pixels and no skew in stereo_K")
        if np.abs(tl[:3, :3] - tr[:3, :3]).max() > _RECTIFIED:
            raise StereoGeometryError("stereo capture: the two cameras are not parallel (the pair is not rectified)")
        d = tl[:3, :3].T @ (tr[:3, 3] - tl[:3, 3])  # the right camera's centre in the left frame
        b = float(d[0])
        if b <= 0 or abs(d[1]) > _RECTIFIED * b or abs(d[2]) > _RECTIFIED * b:
            raise StereoGeometryError(f"stereo capture: the right camera must sit along the left one's +x, it is at {d.tolist()} m")
        return cls(K=K, baseline=b, T_vehicle_left=tl, width=int(w), height=int(h))


def grey(rgb: np.ndarray) -> np.ndarray:
    """Return the luminance (H, W) float32 [DN] of an RGB image (H, W, 3) uint8 (Rec. 601 weights)."""
    im = np.asarray(rgb)
    if im.ndim != 3 or im.shape[2] != 3:
        raise StereoGeometryError(f"stereo capture: expected an RGB image (H, W, 3), got shape {im.shape}")
    f = im.astype(np.float32)
    return f[..., 0] * np.float32(0.299) + f[..., 1] * np.float32(0.587) + f[..., 2] * np.float32(0.114)


@dataclass(frozen=True)
class StereoPair:
    """One pair of grey images (H, W) float32 [DN], `left` and `right`, taken at sim time `stamp` [s]."""

    left: np.ndarray
    right: np.ndarray
    stamp: float

    @classmethod
    def from_capture(cls, obj: Any) -> "StereoPair":
        """Build from any object with the capture's `stereo_left`, `stereo_right` (RGB) and `stamp`."""
        left, right = getattr(obj, "stereo_left", None), getattr(obj, "stereo_right", None)
        if left is None or right is None:
            raise StereoGeometryError("stereo capture: the stereo images are missing (ask for stereo=True)")
        if left.shape != right.shape:
            raise StereoGeometryError(f"stereo capture: left {left.shape} and right {right.shape} images differ in shape")
        return cls(left=grey(left), right=grey(right), stamp=float(obj.stamp))
