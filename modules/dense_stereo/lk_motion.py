"""The vehicle's motion from today's tracker: Shi–Tomasi corners followed by pyramidal Lucas–Kanade in the left
images, each given depth by the step's dense disparity, and FIDO's motion solver on the pairs of 3-D points.

Each step: the previous step's corners are tracked into the new left image (started where the
dead-reckoned motion predicts them, as FIDO's search is), kept when the backward track returns
within `max_back_error` [px] and the new pixel has a disparity; the motion is then fitted; fresh
corners are picked in the new image for the next step.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.fido.errors import MotionError
from modules.fido.motion import Motion, PlanarMotion, estimate_motion
from modules.fido.stereo_pair import StereoPair, StereoRig
from modules.fido.triangulation import StereoPoints, triangulate

__all__ = ["LkConfig", "LkMemory", "LkStep", "lk_step"]


class LkConfig(BaseModel):
    """Corner and tracker settings: corners per image, quality, spacing [px], window [px], pyramid levels,
    backward-track tolerance [px], pixel error [px]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    max_corners: int = Field(100, ge=1)
    quality: float = Field(0.01, gt=0.0, lt=1.0)
    min_distance: float = Field(10.0, gt=0.0)
    window: int = Field(21, ge=5)
    levels: int = Field(3, ge=0)
    max_back_error: float = Field(1.0, gt=0.0)
    pixel_sigma: float = Field(0.5, gt=0.0)


@dataclass(frozen=True)
class LkMemory:
    """The previous step: its left image (H, W) uint8, corners `uv` (N, 2) float32 and their `points`."""

    image: np.ndarray
    uv: np.ndarray
    points: StereoPoints


@dataclass(frozen=True)
class LkStep:
    """A step's motion (`previous ← current`, None on the first step or when it failed: `failure` says why), the
    number of corners tracked, and the memory for the next step."""

    motion: Motion | None
    failure: str | None
    tracked: int
    memory: LkMemory


def _points(uv: np.ndarray, disparity: np.ndarray, rig: StereoRig, sigma: float) -> tuple[np.ndarray, StereoPoints]:
    """Return which left pixels (N, 2) have a disparity, and their triangulated points."""
    iu = np.clip(np.rint(uv[:, 0]).astype(int), 0, disparity.shape[1] - 1)
    iv = np.clip(np.rint(uv[:, 1]).astype(int), 0, disparity.shape[0] - 1)
    d = disparity[iv, iu].astype(np.float64)
    ok = np.isfinite(d)
    right = uv.astype(np.float64) - np.stack([np.where(ok, d, 0.0), np.zeros(len(d))], 1)
    return ok, triangulate(rig, uv.astype(np.float64), right, sigma)


def lk_step(pair: StereoPair, rig: StereoRig, disparity: np.ndarray, previous: LkMemory | None = None,
            odometry: PlanarMotion | None = None, config: LkConfig = LkConfig()) -> LkStep:
    """Track the previous corners into this pair's left image, fit the motion, pick fresh corners."""
    cfg = config
    image = np.clip(np.rint(pair.left), 0, 255).astype(np.uint8)
    motion, failure, tracked = None, "the first step", 0
    if previous is not None and len(previous.uv):
        p0 = previous.uv.reshape(-1, 1, 2).astype(np.float32)
        flags = 0
        p1 = p0.copy()
        in_view = np.ones(len(p0), bool)
        if odometry is not None:  # start where the dead-reckoned motion puts each corner; one it puts out of view is lost
            guess, in_view = rig.project(odometry.to_current(np.nan_to_num(previous.points.xyz)), "left")
            p1 = np.where(in_view[:, None, None], guess.reshape(-1, 1, 2), p0).astype(np.float32)
            flags = cv2.OPTFLOW_USE_INITIAL_FLOW
        lk = dict(winSize=(cfg.window, cfg.window), maxLevel=cfg.levels,
                  criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
        p1, st, _ = cv2.calcOpticalFlowPyrLK(previous.image, image, p0, p1, flags=flags, **lk)
        back, st2, _ = cv2.calcOpticalFlowPyrLK(image, previous.image, p1, None, **lk)  # from the found point, unguided
        good = in_view & (st.ravel() == 1) & (st2.ravel() == 1) & (np.linalg.norm((back - p0).reshape(-1, 2), axis=1) <= cfg.max_back_error)
        h, w = image.shape
        uv1 = p1.reshape(-1, 2)
        good &= (uv1[:, 0] >= 0) & (uv1[:, 0] <= w - 1) & (uv1[:, 1] >= 0) & (uv1[:, 1] <= h - 1)
        has, now = _points(uv1, disparity, rig, cfg.pixel_sigma)
        keep = good & has & now.valid & previous.points.valid
        tracked = int(keep.sum())
        try:
            motion = estimate_motion(previous.points.xyz[keep], previous.points.cov[keep], now.xyz[keep], now.cov[keep])
            failure = None
        except MotionError as exc:
            failure = str(exc)
    corners = cv2.goodFeaturesToTrack(image, cfg.max_corners, cfg.quality, cfg.min_distance)
    uv = np.zeros((0, 2), np.float32) if corners is None else corners.reshape(-1, 2).astype(np.float32)
    has, pts = _points(uv, disparity, rig, cfg.pixel_sigma)
    keep = has & pts.valid
    memory = LkMemory(image=image, uv=uv[keep], points=StereoPoints(pts.xyz[keep], pts.cov[keep], pts.depth[keep], pts.valid[keep]))
    return LkStep(motion=motion, failure=failure, tracked=tracked, memory=memory)
