"""Dense disparity by OpenCV's StereoSGBM, and the points it gives.

The left image is the reference: `disparity[v, u]` = u_left − u_right [px] of the left pixel (u, v).
Settings are those OpenCV's documentation suggests (P1 = 8·block², P2 = 32·block² for one channel,
uniqueness 10 %, speckle filtering); the disparity range covers depths down to `min_depth` [m].
A point's vertical uncertainty comes from a disparity error `disparity_sigma` [px]: σ_Z = Z²·σ_d / (f·b)
along the ray, times the ray's vertical component (the laser detector's test uses it).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.fido.stereo_pair import StereoPair, StereoRig

__all__ = ["SgbmConfig", "sgbm_disparity", "disparity_depth", "disparity_points"]


class SgbmConfig(BaseModel):
    """StereoSGBM settings: block size [px], nearest depth searched [m], uniqueness [%], speckle window [px] and
    range [px], left–right check [px], the disparity error for point uncertainty [px]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    block_size: int = Field(5, ge=1, le=21)
    min_depth: float = Field(1.5, gt=0.0)
    uniqueness: int = Field(10, ge=0, le=100)
    speckle_window: int = Field(100, ge=0)
    speckle_range: int = Field(2, ge=0)
    disp12_max_diff: int = Field(1, ge=-1)
    disparity_sigma: float = Field(0.5, gt=0.0)


def _u8(im: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(im), 0, 255).astype(np.uint8)


def sgbm_disparity(pair: StereoPair, rig: StereoRig, cfg: SgbmConfig = SgbmConfig()) -> np.ndarray:
    """Return the left image's disparity (H, W) float32 [px], NaN where SGBM found none."""
    nd = 16 * int(math.ceil(rig.focal * rig.baseline / cfg.min_depth / 16.0))
    b = cfg.block_size
    m = cv2.StereoSGBM_create(minDisparity=0, numDisparities=nd, blockSize=b, P1=8 * b * b, P2=32 * b * b,
                              disp12MaxDiff=cfg.disp12_max_diff, uniquenessRatio=cfg.uniqueness,
                              speckleWindowSize=cfg.speckle_window, speckleRange=cfg.speckle_range,
                              mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)
    raw = m.compute(_u8(pair.left), _u8(pair.right))
    d = raw.astype(np.float32) / np.float32(16.0)
    d[raw <= 0] = np.nan
    return d


def disparity_depth(disparity: np.ndarray, rig: StereoRig) -> np.ndarray:
    """Return the depth along the left optical axis (H, W) float32 [m] of a disparity image (NaN where none)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return (np.float32(rig.focal * rig.baseline) / disparity).astype(np.float32)


def disparity_points(disparity: np.ndarray, rig: StereoRig, cfg: SgbmConfig = SgbmConfig()) -> np.ndarray:
    """Return the points (N, 4) float32 of every pixel with a disparity: x, y, z in `vehicle` [m] and σ_z [m]."""
    v, u = np.nonzero(np.isfinite(disparity))
    d = disparity[v, u].astype(np.float64)
    f = rig.focal
    Z = f * rig.baseline / d
    ray = np.stack([(u - rig.K[0, 2]) / f, (v - rig.K[1, 2]) / f, np.ones_like(Z)], 1)
    R, t = rig.T_vehicle_left[:3, :3], rig.T_vehicle_left[:3, 3]
    xyz = (ray * Z[:, None]) @ R.T + t
    ray_v = ray @ R.T
    up = np.abs(ray_v[:, 2]) / np.linalg.norm(ray_v, axis=1)
    sig = Z * Z * cfg.disparity_sigma / (f * rig.baseline) * up
    return np.concatenate([xyz, sig[:, None]], axis=1).astype(np.float32)
