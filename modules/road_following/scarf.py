"""SCARF, Supervised Classification Applied to Road Following (Navlab 1990 §2.2.1, §1.2.1, §4.4).

A loop per frame on a reduced image (60×64 by default): classify every pixel against four road and
four off-road Gaussian colour classes, find the triangle road by probability-weighted voting of all
pixels, then re-estimate the colour classes by nearest-mean clustering in the road found and in
the off-road around it — so slow illumination changes and shadows are followed frame by frame.
Optionally the classified image is searched for branch roads (intersections). At the start the
classes are bootstrapped from the road assumed straight ahead (the seed's one external input).

Issue 41 adds the paper's two other parts (Figure 4.2), each off by default: `texture` feeds the
texture operator's image (`texture`, from the blue pyramid) to the classifier as a fourth
measurement, and `colour_model="isodata"` makes the classes by the paper's colour-model generator
(`isodata`) instead of the nearest-mean clustering. A `VisionPool` of several workers reduces,
textures and classifies the frame in row stripes (`scarf_stripes`), with the same result.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.road_following.camera import CameraGeometry
from modules.road_following.colour_classes import ColourClasses, attach_texture, classify, estimate_classes
from modules.road_following.follower import RoadObservation, VehicleMotion
from modules.road_following.intersection import find_branches
from modules.road_following.isodata import isodata_classes
from modules.road_following.scarf_stripes import LookParams, look
from modules.road_following.texture import TEXTURE_ALPHA, TEXTURE_THRESHOLD
from modules.road_following.triangle_road import TriangleRoad, best_triangle, half_width_rate, triangle_in_vehicle, triangle_mask

if TYPE_CHECKING:
    from modules.parallel import VisionPool

__all__ = ["ScarfConfig", "Scarf"]


class ScarfConfig(BaseModel):
    """SCARF's settings: reduced image [px], road width [m], vote grid, class count, acceptance, intersections."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    rows: int = Field(60, ge=16)
    cols: int = Field(64, ge=16)
    road_width_m: float = Field(6.0, gt=0.0)
    classes_per_side: int = Field(4, ge=1, le=8)
    apex_step_px: float = Field(0.5, gt=0.0)
    skew_max_deg: float = Field(70.0, gt=0.0, lt=89.0)
    skew_step_deg: float = Field(1.0, gt=0.0)
    accept: float = Field(0.5, gt=0.0, lt=1.0)  # mean P(road) inside the triangle to call it road
    road_margin: float = Field(0.75, gt=0.0, le=1.0)  # road training set: this share of the half width
    offroad_margin: float = Field(1.35, ge=1.0)  # off-road training set: outside this multiple of it
    intersections: bool = False
    texture: bool = False  # issue 41: the texture operator's image as the classifier's fourth measurement
    texture_alpha: float = Field(TEXTURE_ALPHA, ge=0.0, le=1.0)
    texture_threshold: float = Field(TEXTURE_THRESHOLD, gt=0.0)
    colour_model: Literal["nearest_mean", "isodata"] = "nearest_mean"  # issue 41: the paper's generator is "isodata"


class Scarf:
    """SCARF on one camera: `observe` a frame, get the road (see module docstring)."""

    def __init__(self, camera: CameraGeometry, config: ScarfConfig = ScarfConfig(), *, prior_lateral_m: float = 0.0,
                 prior_heading_rad: float = 0.0, pool: "VisionPool | None" = None) -> None:
        """Set up for `camera` (full-size image); the bootstrap road is the prior (lateral [m], heading [rad]); `pool`: vision workers."""
        self.camera = camera
        self.config = config
        self.pool = pool
        self.small = camera.scaled(config.cols, config.rows)
        self.k = half_width_rate(self.small, config.road_width_m)
        self.horizon = self.small.horizon_row
        span = 3.0 * self.k * (config.rows - self.horizon)
        self.apex_cols = np.arange(-span, config.cols + span, config.apex_step_px)
        lim = math.radians(config.skew_max_deg)
        self.skews = np.arange(-lim, lim + 1e-9, math.radians(config.skew_step_deg))
        self.classes: ColourClasses | None = None
        self.road: TriangleRoad | None = None
        self._prior = (prior_lateral_m, prior_heading_rad)

    def reduce(self, image: np.ndarray) -> np.ndarray:
        """Return the reduced image (rows, cols, 3) float32 [0–255] (area averaging)."""
        c = self.config
        return look(self.camera.check_image(image), LookParams(c.rows, c.cols, False, c.texture_alpha, c.texture_threshold, None)).rgb

    def _prior_triangle(self) -> TriangleRoad:
        """Return the triangle of the prior road (for the bootstrap)."""
        lat, hd = self._prior
        pts = np.array([[8.0, lat + 8.0 * math.tan(hd)], [30.0, lat + 30.0 * math.tan(hd)]])
        u, v, _ = self.small.project_ground(pts)
        skew = math.atan2(u[1] - u[0], v[0] - v[1])
        apex = float(u[1] + (v[1] - self.horizon) * math.tan(skew))
        return TriangleRoad(apex_col=apex, skew_rad=skew, horizon_row=self.horizon, half_width_rate=self.k)

    def _learn(self, rgb: np.ndarray, road: TriangleRoad, texture: np.ndarray | None = None) -> None:
        """Re-estimate the colour classes from the road found (nearest-mean clustering or ISODATA on each side)."""
        c = self.config
        below = np.arange(c.rows)[:, None] > self.horizon + 1.0
        inner = triangle_mask(rgb.shape[:2], road, c.road_margin) & below
        outer = ~triangle_mask(rgb.shape[:2], road, c.offroad_margin) & below
        if c.colour_model == "isodata":
            got = isodata_classes(rgb, inner, outer, self.classes, k=c.classes_per_side)
        else:
            got = estimate_classes(rgb, inner, outer, self.classes, k=c.classes_per_side)
        if got is not None and texture is not None:
            got = attach_texture(got, texture, inner, outer, self.classes)
        if got is not None:
            self.classes = got

    def observe(self, image: np.ndarray, *, speed_mps: float = 0.0, stamp: float = 0.0,
                motion: VehicleMotion | None = None) -> RoadObservation:
        """Find the road in `image` (H, W, 3) uint8 (see module docstring); `motion` is not needed by SCARF."""
        t0 = time.perf_counter()
        c = self.config
        seen = look(self.camera.check_image(image),
                    LookParams(c.rows, c.cols, c.texture, c.texture_alpha, c.texture_threshold, self.classes), self.pool)
        rgb, texture = seen.rgb, seen.texture
        if self.classes is None:
            self._learn(rgb, self._prior_triangle(), texture)
        if self.classes is None:
            return RoadObservation(method="scarf", stamp=stamp, found=False, confidence=0.0,
                                   ms_per_frame=(time.perf_counter() - t0) * 1e3)
        cl = seen.classified if seen.classified is not None else classify(rgb, self.classes, texture)
        weight = 2.0 * cl.p_road - 1.0
        road = best_triangle(weight, self.horizon, self.k, self.apex_cols, self.skews)
        inside = triangle_mask(rgb.shape[:2], road)
        probability = float(cl.p_road[inside].mean()) if inside.any() else 0.0
        found = probability > self.config.accept
        lateral, heading = triangle_in_vehicle(road, self.small)
        branches = ()
        if found:
            self.road = road
            self._learn(rgb, road, texture)
            if self.config.intersections:
                branches = find_branches(cl.p_road, self.small.ground_grid, lateral, heading, self.config.road_width_m)
        return RoadObservation(method="scarf", stamp=stamp, found=found, lateral_offset_m=lateral, heading_rad=heading,
                               confidence=min(max(probability, 0.0), 1.0), ms_per_frame=(time.perf_counter() - t0) * 1e3,
                               branches=branches)
