"""One FIDO step (Navlab 1990 §4.3.1, Figure 4.1): track the known features, find new ones, locate them in 3-D.

Each step takes a new left and right image and
1. reduces both to their pyramids;
2. finds every previously known feature in the new right image by pyramid correlation (from the
   previous right image): the ones found are *tracked*. Given the vehicle's own idea of its motion
   since the last step (dead reckoning, as FIDO used it to restrict the search), each feature's
   3-D position predicts where it reappears and the search starts there, at the pyramid level
   `track_top_level`; without it the search is the full coarse-to-fine one from the 8×8 level;
3. finds each tracked feature of the new right image in the new left image (from the predicted
   disparity, when there is a prediction) and triangulates it;
4. estimates the vehicle's motion since the previous step from the tracked features' two 3-D
   positions (tracks inconsistent with the motion are dropped, as the Cart did);
5. picks new features with the interest operator in the right pyramid (away from the tracked ones),
   finds them in the left image and triangulates them;
6. keeps tracked and new features as the next step's known features, and marks the obstacles.

A stereo match counts when its correlation is at least `min_score`, its level-0 peak lies inside the
search area and, the pair being rectified, the two rows agree within `max_row_error` [px] with a
positive disparity. `fido_step` is a pure function: what the next step needs travels in
`FidoStep.memory`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.fido.correlation import Matches, pyramid_correlate
from modules.fido.errors import FidoError, MotionError
from modules.fido.interest import interest_map, select_features
from modules.fido.motion import Motion, PlanarMotion, estimate_motion
from modules.fido.obstacle_features import obstacle_mask
from modules.fido.pyramid import PYRAMID_LEVELS, build_pyramid, from_level
from modules.fido.stereo_pair import StereoPair, StereoRig
from modules.fido.triangulation import StereoPoints, triangulate

__all__ = ["FidoConfig", "FeatureTable", "FidoMemory", "StepTiming", "FidoStep", "fido_step"]


class FidoConfig(BaseModel):
    """FIDO's settings: pyramid levels, the interest operator's grid and floor [DN²], correlation acceptance,
    feature budget, pixel error [px], obstacle heights and reach [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    levels: int = Field(PYRAMID_LEVELS, ge=1, le=12)
    grid: int = Field(10, ge=1, le=64)  # the paper's 10×10 subimages
    interest_level: int = Field(0, ge=0)  # the pyramid level the interest operator looks at
    # [DN²] mean squared difference: 4–5 times what the camera's noise gives a flat patch (2.5 DN per channel: 5.6 DN²)
    min_interest: float = Field(25.0, ge=0.0)
    min_separation: float = Field(8.0, ge=0.0)  # [px] a new feature this close to a tracked one is the same one
    max_features: int = Field(100, ge=1)  # known features kept per step (the grid's hundred)
    min_score: float = Field(0.5, ge=-1.0, le=1.0)  # CORR / 8 a match needs
    subpixel: bool = False  # refine each level-0 peak by a parabola (not the paper's; see `correlation`)
    track_top_level: int = Field(3, ge=0)  # a predicted search starts here: ±2 px per level, ±30 px from level 3
    max_row_error: float = Field(1.0, gt=0.0)  # [px] rectified pair: the two rows of a stereo match agree
    pixel_sigma: float = Field(0.5, gt=0.0)  # [px] a match's error in each image, for the covariances
    obstacle_min_height: float = Field(0.3, gt=0.0)  # [m] above the vehicle's ground plane
    obstacle_max_height: float = Field(3.0, gt=0.0)  # [m] higher features pass overhead
    obstacle_max_distance: float = Field(20.0, gt=0.0)  # [m]


@dataclass(frozen=True)
class FeatureTable:
    """The known features after a step, tracked ones first: `ids` (N,) int64 (kept while tracked), `uv_right`,
    `uv_left` (N, 2) float64 pixels in this step's images, `xyz` (N, 3) float64 `vehicle` [m], `cov` (N, 3, 3)
    float64 [m²], `depth` (N,) float64 along the left optical axis [m], `age` (N,) int32 steps tracked,
    `tracked` (N,) bool (found again this step rather than new)."""

    ids: np.ndarray
    uv_right: np.ndarray
    uv_left: np.ndarray
    xyz: np.ndarray
    cov: np.ndarray
    depth: np.ndarray
    age: np.ndarray
    tracked: np.ndarray

    def __len__(self) -> int:
        return int(len(self.ids))

    @staticmethod
    def empty() -> "FeatureTable":
        """Return a table without features."""
        return FeatureTable(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 3)), np.zeros((0, 3, 3)),
                            np.zeros(0), np.zeros(0, np.int32), np.zeros(0, bool))


@dataclass(frozen=True)
class FidoMemory:
    """What the next step needs: this step's right pyramid, its features, the next free feature id."""

    right_pyramid: tuple[np.ndarray, ...]
    features: FeatureTable
    next_id: int


@dataclass(frozen=True)
class StepTiming:
    """Wall time of a step's parts [ms]: pyramids, tracking, stereo matching (tracked and new), interest operator, motion, total."""

    pyramid_ms: float
    track_ms: float
    stereo_ms: float
    interest_ms: float
    motion_ms: float
    total_ms: float


@dataclass(frozen=True)
class FidoStep:
    """A step's result: `features`, `obstacle` (N,) bool over them, `motion` (`previous ← current`; None on the
    first step or when it could not be estimated, `motion_failure` then says why), `timing`, and `memory`."""

    features: FeatureTable
    obstacle: np.ndarray
    motion: Motion | None
    motion_failure: str | None
    timing: StepTiming
    memory: FidoMemory


def _stereo(right: tuple[np.ndarray, ...], left: tuple[np.ndarray, ...], uv_right: np.ndarray, rig: StereoRig,
            cfg: FidoConfig, predicted: np.ndarray | None = None) -> tuple[Matches, StereoPoints, np.ndarray]:
    """Find features of the right image in the left one (from `predicted` left pixels when given) and triangulate them;
    return the matches, points, accepted mask."""
    top = min(cfg.track_top_level, len(right) - 1) if predicted is not None else None
    m = pyramid_correlate(right, left, uv_right, predicted=predicted, top_level=top, subpixel=cfg.subpixel)
    pts = triangulate(rig, m.uv, uv_right, cfg.pixel_sigma)
    ok = (m.score >= cfg.min_score) & m.interior & (np.abs(m.uv[:, 1] - uv_right[:, 1]) <= cfg.max_row_error) & pts.valid
    return m, pts, ok


def fido_step(pair: StereoPair, rig: StereoRig, previous: FidoMemory | None = None,
              config: FidoConfig = FidoConfig(), odometry: PlanarMotion | None = None) -> FidoStep:
    """Run one FIDO step on a stereo pair (see the module docstring); `previous` is the last step's `memory`,
    `odometry` the vehicle's dead-reckoned motion since then (`previous ← current`), which only guides the search."""
    cfg = config
    if pair.left.shape != (rig.height, rig.width):
        raise FidoError(f"FIDO: images of shape {pair.left.shape} do not fit the rig's {rig.width}×{rig.height}")
    if cfg.interest_level >= cfg.levels:
        raise FidoError(f"FIDO: interest level {cfg.interest_level} outside the {cfg.levels}-level pyramid")
    t0 = time.perf_counter()
    left = build_pyramid(pair.left, cfg.levels)
    right = build_pyramid(pair.right, cfg.levels)
    t1 = time.perf_counter()

    # tracked features: previous right image → new right image → new left image
    prev = previous.features if previous is not None else FeatureTable.empty()
    motion: Motion | None = None
    failure: str | None = "the first step" if previous is None else None
    tracked = np.zeros(0, np.int64)
    tr_uv = np.zeros((0, 2))
    t_stereo = 0.0
    if previous is not None and len(prev):
        search = np.arange(len(prev))
        guess = guess_left = None
        if odometry is not None:
            moved = odometry.to_current(prev.xyz)
            guess, in_right = rig.project(moved, "right")
            guess_left, in_left = rig.project(moved, "left")
            search = np.nonzero(in_right & in_left)[0]
            guess, guess_left = guess[search], guess_left[search]
        top = min(cfg.track_top_level, cfg.levels - 1) if odometry is not None else None
        tm = pyramid_correlate(previous.right_pyramid, right, prev.uv_right[search], predicted=guess, top_level=top,
                               subpixel=cfg.subpixel)
        hit = (tm.score >= cfg.min_score) & tm.interior
        found = search[hit]
        t2 = time.perf_counter()
        sm, pts, ok = _stereo(right, left, tm.uv[hit], rig, cfg,
                              None if guess_left is None else tm.uv[hit] + (guess_left - guess)[hit])
        t_stereo += time.perf_counter() - t2
        tracked, tr_uv = found[ok], tm.uv[hit][ok]
        tr_left = sm.uv[ok]
        tr_pts = StereoPoints(pts.xyz[ok], pts.cov[ok], pts.depth[ok], pts.valid[ok])
    else:
        tr_left = np.zeros((0, 2))
        tr_pts = StereoPoints(np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0), np.zeros(0, bool))
    t3 = time.perf_counter()
    track_ms = 1e3 * (t3 - t1) - 1e3 * t_stereo
    if previous is not None:
        try:
            motion = estimate_motion(prev.xyz[tracked], prev.cov[tracked], tr_pts.xyz, tr_pts.cov)
            keep = motion.inliers
        except MotionError as exc:
            failure = str(exc)
            keep = np.ones(len(tracked), bool)
        tracked, tr_uv, tr_left = tracked[keep], tr_uv[keep], tr_left[keep]
        tr_pts = StereoPoints(tr_pts.xyz[keep], tr_pts.cov[keep], tr_pts.depth[keep], tr_pts.valid[keep])
    t4 = time.perf_counter()

    # new features from the interest operator in the right pyramid
    room = cfg.max_features - len(tracked)
    if room > 0:
        lev = cfg.interest_level
        cand = select_features(interest_map(right[lev]), cfg.grid, cfg.min_interest,
                               exclude=tr_uv, min_separation=cfg.min_separation)
        new_uv = from_level(cand.uv, lev)[:room]
    else:
        new_uv = np.zeros((0, 2))
    t5 = time.perf_counter()
    sm, pts, ok = _stereo(right, left, new_uv, rig, cfg)
    t6 = time.perf_counter()
    n_new = int(ok.sum())
    next_id = previous.next_id if previous is not None else 0
    features = FeatureTable(
        ids=np.concatenate([prev.ids[tracked], np.arange(next_id, next_id + n_new, dtype=np.int64)]),
        uv_right=np.concatenate([tr_uv, new_uv[ok]]).reshape(-1, 2),
        uv_left=np.concatenate([tr_left, sm.uv[ok]]).reshape(-1, 2),
        xyz=np.concatenate([tr_pts.xyz, pts.xyz[ok]]).reshape(-1, 3),
        cov=np.concatenate([tr_pts.cov, pts.cov[ok]]).reshape(-1, 3, 3),
        depth=np.concatenate([tr_pts.depth, pts.depth[ok]]),
        age=np.concatenate([prev.age[tracked] + 1, np.zeros(n_new, np.int32)]).astype(np.int32),
        tracked=np.concatenate([np.ones(len(tracked), bool), np.zeros(n_new, bool)]),
    )
    all_pts = StereoPoints(features.xyz, features.cov, features.depth, np.isfinite(features.depth))
    obstacle = obstacle_mask(all_pts, cfg.obstacle_min_height, cfg.obstacle_max_height, cfg.obstacle_max_distance)
    t7 = time.perf_counter()
    timing = StepTiming(pyramid_ms=1e3 * (t1 - t0), track_ms=track_ms, stereo_ms=1e3 * (t_stereo + t6 - t5),
                        interest_ms=1e3 * (t5 - t4), motion_ms=1e3 * (t4 - t3), total_ms=1e3 * (t7 - t0))
    return FidoStep(features=features, obstacle=obstacle, motion=motion, motion_failure=failure, timing=timing,
                    memory=FidoMemory(right_pyramid=right, features=features, next_id=next_id + n_new))
