"""Triangulation: a feature's 3-D position from its two images in the rectified pair, with its uncertainty.

With disparity d = u_left − u_right [px], focal length f [px] and baseline b [m], the point in the
left camera's frame is Z = f·b/d, X = (u_left − c_u)·Z/f, Y = (v − c_v)·Z/f (v the mean of the two
rows). Its covariance comes from an isotropic pixel error σ [px] in each image through the
Jacobian of these equations (as Matthies and Shafer modelled stereo error: long along the ray,
growing with Z²). Points with d ≤ 0 lie at or beyond infinity and are not valid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modules.fido.stereo_pair import StereoRig

__all__ = ["StereoPoints", "triangulate"]


@dataclass(frozen=True)
class StereoPoints:
    """Triangulated features: `xyz` (N, 3) float64 `vehicle` [m], `cov` (N, 3, 3) float64 `vehicle` [m²],
    `depth` (N,) float64 along the left optical axis [m] (inf where not valid), `valid` (N,) bool (d > 0)."""

    xyz: np.ndarray
    cov: np.ndarray
    depth: np.ndarray
    valid: np.ndarray


def triangulate(rig: StereoRig, uv_left: np.ndarray, uv_right: np.ndarray, pixel_sigma: float = 0.5) -> StereoPoints:
    """Return the 3-D points of features at pixels `uv_left`, `uv_right` (N, 2) of the pair, `pixel_sigma` [px] per image."""
    ul, ur = np.asarray(uv_left, np.float64).reshape(-1, 2), np.asarray(uv_right, np.float64).reshape(-1, 2)
    f, cu, cv = rig.focal, float(rig.K[0, 2]), float(rig.K[1, 2])
    d = ul[:, 0] - ur[:, 0]
    valid = d > 0
    ds = np.where(valid, d, 1.0)
    Z = f * rig.baseline / ds
    X = (ul[:, 0] - cu) * Z / f
    Y = (0.5 * (ul[:, 1] + ur[:, 1]) - cv) * Z / f
    cam = np.stack([X, Y, Z], 1)
    # Jacobian of (X, Y, Z) by (u_left, u_right, v)
    J = np.zeros((len(d), 3, 3))
    J[:, 0, 0], J[:, 0, 1] = Z / f - X / ds, X / ds
    J[:, 1, 0], J[:, 1, 1], J[:, 1, 2] = -Y / ds, Y / ds, Z / f
    J[:, 2, 0], J[:, 2, 1] = -Z / ds, Z / ds
    s2 = float(pixel_sigma) ** 2
    cov_cam = J @ np.diag([s2, s2, 0.5 * s2]) @ J.transpose(0, 2, 1)
    R, t = rig.T_vehicle_left[:3, :3], rig.T_vehicle_left[:3, 3]
    xyz = cam @ R.T + t
    cov = R @ cov_cam @ R.T
    xyz[~valid] = np.nan
    return StereoPoints(xyz=xyz, cov=cov, depth=np.where(valid, Z, np.inf), valid=valid)
