"""YARF, Yet Another Road Follower (Navlab 1990 §2.2.2, §1.2.2, ch. 5): explicit features, a parabolic spine.

The road model is a generalized stripe: features at known offsets from a spine (a double yellow
centre line on it, white stripes at the lane edges). Each frame runs predict–segment–fit–move:
the spine predicted from the last frame and the vehicle's motion places a window for every
feature at several distances ahead (while the road is being acquired or was lost: wider windows,
near ones only, and a straight road); the trackers look in them and report found / missing /
clipped / illumination shift / too large; every found feature, moved back onto the spine by its
offset, joins the points of the last three frames (carried into the current vehicle frame by the
odometry), and the spine is the robust M-estimate through them, which rejects outliers. At the
start the spine is a prior (the seed's bootstrap: the vehicle in its lane, along the road) — or,
without one (`prior=None`, issue 41), the road is located by the vanishing-point Hough
(`yarf_bootstrap`, §5.5) in each frame until YARF has found it once.
"""

from __future__ import annotations

import math
import time
from collections import deque

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.road_following.camera import CameraGeometry
from modules.road_following.follower import FeatureReport, RoadObservation, VehicleMotion
from modules.road_following.spine_fit import Spine, fit_spine_lsq, fit_spine_robust
from modules.road_following.yarf_bootstrap import BootstrapConfig, bootstrap_spine
from modules.road_following.yarf_trackers import BrightnessModel, predict_window, track_white, track_yellow

__all__ = ["StripeFeature", "LaneModel", "YarfConfig", "Yarf"]


class StripeFeature(BaseModel):
    """One painted feature of the cross-section: kind, offset from the spine [m] (+ left), painted width [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: str = Field(pattern="^(yellow|white)$")
    offset_m: float
    width_m: float = Field(gt=0.0)


class LaneModel(BaseModel):
    """The road's cross-section (§5.4): its features; the default is a two-lane road, 3.55 m to each edge stripe."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    features: tuple[StripeFeature, ...] = (
        StripeFeature(kind="yellow", offset_m=0.0, width_m=0.34),
        StripeFeature(kind="white", offset_m=-3.55, width_m=0.12),
        StripeFeature(kind="white", offset_m=3.55, width_m=0.12),
    )


class YarfConfig(BaseModel):
    """YARF's settings: window distances [m] and half width [m], frames fitted, hue range [deg], limits."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    lookaheads_m: tuple[float, ...] = (7.0, 8.5, 10.0, 12.0, 14.0, 16.5, 19.5, 23.0)
    window_half_m: float = Field(0.9, gt=0.0)
    acquire_half_m: float = Field(2.2, gt=0.0)  # window half width [m] while (re)acquiring the road
    frames_fitted: int = Field(3, ge=1)
    hue_range_deg: tuple[float, float] = (40.0, 100.0)
    min_saturation: float = Field(0.1, ge=0.0, le=1.0)
    max_curvature_per_m: float = Field(1.0 / 25.0, gt=0.0)
    curvature_sigma_per_m: float = Field(0.004, gt=0.0)  # how much the curvature may change per frame [1/m]
    max_jump_m: float = Field(0.8, gt=0.0)  # largest plausible change of the spine at 12 m between frames [m]
    acquire_jump_m: float = Field(2.5, gt=0.0)  # the same while (re)acquiring [m]
    min_points: int = Field(5, ge=3)
    min_current_points: int = Field(4, ge=1)  # features found in this very frame to call the road found
    acquire_max_m: float = Field(14.0, gt=0.0)  # while acquiring: only windows this near, and a straight road


class Yarf:
    """YARF on one camera (see module docstring); `observe` one frame after another."""

    def __init__(self, camera: CameraGeometry, lane: LaneModel = LaneModel(), config: YarfConfig = YarfConfig(), *,
                 prior: Spine | None = Spine(offset=1.75), bootstrap: BootstrapConfig = BootstrapConfig()) -> None:
        """Set up for `camera`; `prior` is the starting spine in `vehicle` (default: driving in the right lane; None: locate the road by the vanishing-point Hough)."""
        self.camera = camera
        self.lane = lane
        self.config = config
        self.bootstrap = bootstrap
        self.located = prior is not None  # a spine to acquire from: the prior, or the Hough's, or the road found
        self.spine = prior if prior is not None else Spine()
        self._history: deque[np.ndarray] = deque(maxlen=config.frames_fitted)  # (N, 2) spine samples per frame
        self._models: dict[int, BrightnessModel] = {}
        self._last_stamp: float | None = None
        self.tracking = False  # False: bootstrapping or lost, wide windows

    def _move(self, motion: VehicleMotion) -> None:
        """Carry the spine and the kept points into the new vehicle frame."""
        xs = np.linspace(-5.0, 30.0, 15)
        pts = motion.to_new(np.stack([xs, self.spine.lateral(xs)], -1))
        self.spine = fit_spine_lsq(pts[:, 0], pts[:, 1])
        self._history = deque((motion.to_new(h) if len(h) else h for h in self._history), maxlen=self.config.frames_fitted)

    def _look(self, image: np.ndarray) -> tuple[list[FeatureReport], np.ndarray]:
        """Run every tracker in its predicted window; return the reports and the spine samples (N, 2) [m]."""
        cfg = self.config
        reports: list[FeatureReport] = []
        samples = []
        for fi, feat in enumerate(self.lane.features):
            for x in cfg.lookaheads_m:
                if not self.tracking and x > cfg.acquire_max_m:
                    continue
                half_len = max(0.5, 0.06 * x)
                xs = np.linspace(x - half_len, x + half_len, 9)
                slope = 0.5 * self.spine.curvature * 2 * xs + self.spine.slope
                ys = self.spine.lateral(xs) + feat.offset_m * np.sqrt(1.0 + slope * slope)
                half = cfg.window_half_m if self.tracking else cfg.acquire_half_m
                win = predict_window(self.camera, np.stack([xs, ys], -1), half)
                if win is None:
                    continue
                if feat.kind == "yellow":
                    res = track_yellow(image, win, feat.width_m, hue_range=cfg.hue_range_deg, min_saturation=cfg.min_saturation)
                else:
                    key = fi * 100 + int(x * 2)
                    res, self._models[key] = track_white(image, win, feat.width_m, self._models.get(key, BrightnessModel()))
                point = None
                if res.status == "found" and res.uv is not None:
                    g = self.camera.ground_points(np.array([res.uv[0]]), np.array([res.uv[1]]))[0]
                    if np.isfinite(g).all():
                        point = (float(g[0]), float(g[1]))
                        slope_g = self.spine.curvature * g[0] + self.spine.slope
                        samples.append((g[0], g[1] - feat.offset_m * math.sqrt(1.0 + slope_g * slope_g)))
                reports.append(FeatureReport(kind=feat.kind, offset_m=feat.offset_m, lookahead_m=x,  # type: ignore[arg-type]
                                             status=res.status, point=point, score=float(res.score)))
        return reports, np.asarray(samples, float).reshape(-1, 2)

    def observe(self, image: np.ndarray, *, speed_mps: float = 0.0, stamp: float = 0.0,
                motion: VehicleMotion | None = None) -> RoadObservation:
        """Track the features in `image` (H, W, 3) uint8 and fit the spine; `motion` since the last frame (else speed × dt)."""
        t0 = time.perf_counter()
        self.camera.check_image(image)
        if motion is None and self._last_stamp is not None:
            motion = VehicleMotion.straight(speed_mps, stamp - self._last_stamp)
        if motion is not None:
            self._move(motion)
        self._last_stamp = stamp
        if not self.located:
            located = bootstrap_spine(image, self.camera, tuple((f.kind, f.offset_m) for f in self.lane.features), self.bootstrap)
            if located.spine is None:
                return RoadObservation(method="yarf", stamp=stamp, found=False, confidence=0.0,
                                       ms_per_frame=(time.perf_counter() - t0) * 1e3)
            self.spine = located.spine
            self._history.clear()  # points of a frame that found no road belonged to another guess
        reports, samples = self._look(image)
        self._history.append(samples)
        pts = np.vstack([h for h in self._history if len(h)]) if any(len(h) for h in self._history) else np.zeros((0, 2))
        found = False
        inlier_share = 0.0
        if len(pts) >= self.config.min_points:
            cfg = self.config
            prior = (self.spine.curvature, cfg.curvature_sigma_per_m) if self.tracking else (0.0, 1e-4)
            fit = fit_spine_robust(pts[:, 0], pts[:, 1], curvature_prior=prior)
            n_in = int(fit.inliers.sum())
            inlier_share = n_in / len(pts)
            c = float(np.clip(fit.spine.curvature, -cfg.max_curvature_per_m, cfg.max_curvature_per_m))
            # global consistency: the road cannot jump between frames; a fit that does is rejected
            jump = float(np.max(np.abs(fit.spine.lateral(np.array([0.0, 12.0])) - self.spine.lateral(np.array([0.0, 12.0])))))
            if (n_in >= cfg.min_points and len(samples) >= cfg.min_current_points and fit.scale_m < 0.5
                    and jump <= (cfg.max_jump_m if self.tracking else cfg.acquire_jump_m)):
                self.spine = fit.spine.model_copy(update={"curvature": c})
                found = True
                # outliers found now are dropped from the kept points of this frame
                cur = self._history[-1]
                if len(cur):
                    r = np.abs(cur[:, 1] - self.spine.lateral(cur[:, 0]))
                    self._history[-1] = cur[r < 4.685 * fit.scale_m]
        self.tracking = found
        self.located = self.located or found
        seen = sum(r.status == "found" for r in reports)
        confidence = (seen / max(len(reports), 1)) * inlier_share if found else 0.0
        s = self.spine
        return RoadObservation(method="yarf", stamp=stamp, found=found, lateral_offset_m=s.offset, heading_rad=math.atan(s.slope),
                               road_curvature_per_m=s.curvature, confidence=float(min(max(confidence, 0.0), 1.0)),
                               ms_per_frame=(time.perf_counter() - t0) * 1e3, features=tuple(reports))
