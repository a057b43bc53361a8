"""YARF's feature trackers (Navlab 1990 §2.2.2, §5.3): the yellow line by hue, the white stripe as a bright bar.

Each tracker looks in a small window around where the road model predicts its feature. The window
is a parallelogram: every row is shifted along the predicted line, so a stripe at the predicted
orientation stands upright in it. The yellow tracker keeps pixels of hue 40–100 [deg, red = 0]
with a saturation of at least 0.1 (near-grey pixels have an unstable hue), cleans the mask with a
shrink-and-grow (opening), and returns the centroid of the dominant blob(s). The white tracker
correlates the blue band, blurred along the bar, with a ±1 mask of the stripe's width flanked by
road. Each reports a local verdict: found, missing, clipped (at the window's edge), illumination
shift (the window far brighter or darker than its model), too large (a blob wider than any line).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from pydantic import BaseModel, ConfigDict

from modules.road_following.camera import CameraGeometry
from modules.road_following.follower import FeatureStatus

__all__ = ["Window", "TrackResult", "predict_window", "hue_saturation", "yellow_mask", "shrink_and_grow", "track_yellow",
           "track_white", "BrightnessModel"]


class Window(BaseModel):
    """A parallelogram window: image rows [px], the predicted feature column per row [px], half width [px], px per metre."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    rows: np.ndarray  # (R,) int
    cols: np.ndarray  # (R,) float, predicted feature column
    half_px: int
    px_per_m: float

    def extract(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the window's pixels (R, 2·half+1, C) and (R, 2·half+1) bool inside-the-image."""
        h, w = image.shape[:2]
        offs = np.arange(-self.half_px, self.half_px + 1)
        cc = np.round(self.cols).astype(np.int64)[:, None] + offs[None, :]
        inside = (cc >= 0) & (cc < w)
        pix = image[self.rows[:, None], np.clip(cc, 0, w - 1)]
        return pix, inside

    def to_image(self, row_index: float, col_offset: float) -> tuple[float, float]:
        """Return image (u, v) [px] of a window position (row index, column offset from the left edge)."""
        i = int(np.clip(round(row_index), 0, len(self.rows) - 1))
        return float(np.round(self.cols[i]) - self.half_px + col_offset), float(self.rows[i])


class TrackResult(BaseModel):
    """One tracker's output: its verdict, where the feature is in the image [px] when found, a score."""

    model_config = ConfigDict(frozen=True)

    status: FeatureStatus
    uv: tuple[float, float] | None = None
    score: float = 0.0


def predict_window(camera: CameraGeometry, line_xy: np.ndarray, half_m: float, min_rows: int = 3) -> Window | None:
    """Return the window around the predicted feature line `line_xy` (N, 2) [m] in `vehicle`, ±`half_m` [m] across.

    None when the line does not fall in the image.
    """
    u, v, front = camera.project_ground(line_xy)
    ok = front & np.isfinite(u) & (v >= 0) & (v <= camera.height - 1)
    if ok.sum() < 2:
        return None
    u, v = u[ok], v[ok]
    r0, r1 = int(math.ceil(v.min())), int(math.floor(v.max()))
    if r1 - r0 + 1 < min_rows:
        mid = 0.5 * (v.min() + v.max())
        r0, r1 = int(round(mid - (min_rows - 1) / 2)), int(round(mid + (min_rows - 1) / 2))
        r0, r1 = max(r0, 0), min(r1, camera.height - 1)
    rows = np.arange(r0, r1 + 1)
    order = np.argsort(v)
    cols = np.interp(rows, v[order], u[order])
    mid_xy = line_xy[ok][len(u) // 2]
    ua, _, _ = camera.project_ground(np.array([[mid_xy[0], mid_xy[1] + 0.5], [mid_xy[0], mid_xy[1] - 0.5]]))
    ppm = float(abs(ua[1] - ua[0]))
    if not (math.isfinite(ppm) and ppm > 0):
        return None
    half = max(int(math.ceil(half_m * ppm)), 3)
    return Window(rows=rows, cols=cols, half_px=half, px_per_m=ppm)


def hue_saturation(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return hue [deg, 0–360, red = 0] and saturation [0–1] of `rgb` (..., 3)."""
    x = rgb.astype(np.float32)
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    mx = x.max(axis=-1)
    mn = x.min(axis=-1)
    d = np.maximum(mx - mn, 1e-6)
    h = np.where(mx == r, ((g - b) / d) % 6.0, np.where(mx == g, (b - r) / d + 2.0, (r - g) / d + 4.0)) * 60.0
    s = (mx - mn) / np.maximum(mx, 1e-6)
    return h, s


def yellow_mask(rgb: np.ndarray, hue_range: tuple[float, float] = (40.0, 100.0), min_saturation: float = 0.1) -> np.ndarray:
    """Return the pixels of `rgb` (..., 3) whose hue lies in `hue_range` [deg] with enough saturation."""
    h, s = hue_saturation(rgb)
    return (h >= hue_range[0]) & (h <= hue_range[1]) & (s >= min_saturation)


def shrink_and_grow(mask: np.ndarray) -> np.ndarray:
    """Return `mask` (R, W) bool after a shrink and a grow along the rows' direction (isolated points removed)."""
    k = np.ones((2, 1), np.uint8) if mask.shape[0] >= 2 else np.ones((1, 2), np.uint8)
    return cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_OPEN, k, borderType=cv2.BORDER_CONSTANT, borderValue=0).astype(bool)


def track_yellow(image: np.ndarray, win: Window, line_width_m: float, *, hue_range: tuple[float, float] = (40.0, 100.0),
                 min_saturation: float = 0.1) -> TrackResult:
    """Find the yellow line in `win` of `image` (H, W, 3) uint8: hue threshold, shrink and grow, dominant blob."""
    pix, inside = win.extract(image)
    mask = yellow_mask(pix, hue_range, min_saturation) & inside
    mask = shrink_and_grow(mask)
    expected = len(win.rows) * max(line_width_m * win.px_per_m, 1.0)
    area = int(mask.sum())
    if area < 0.25 * expected:
        return TrackResult(status="missing", score=area / max(expected, 1e-9))
    if area > 4.0 * expected + 4 or area > 0.6 * mask.size:
        return TrackResult(status="too_large", score=area / max(expected, 1e-9))
    n, lab, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    areas = stats[1:, cv2.CC_STAT_AREA]
    big = 1 + np.flatnonzero(areas >= 0.3 * areas.max())
    keep = np.isin(lab, big)
    rr, cc = np.nonzero(keep)
    colm = float(cc.mean())
    width_px = 2 * win.half_px + 1
    if colm < 1.0 or colm > width_px - 2.0:
        return TrackResult(status="clipped", score=area / expected)
    u, v = win.to_image(float(rr.mean()), colm)
    return TrackResult(status="found", uv=(u, v), score=min(area / expected, 4.0))


class BrightnessModel(BaseModel):
    """A white-stripe tracker's model of its window: mean blue level of the road around the stripe [DN]."""

    model_config = ConfigDict(frozen=True)

    background: float | None = None

    def updated(self, level: float, rate: float = 0.3) -> "BrightnessModel":
        """Return the model moved towards `level` [DN]."""
        b = level if self.background is None else (1.0 - rate) * self.background + rate * level
        return BrightnessModel(background=b)


def track_white(image: np.ndarray, win: Window, stripe_width_m: float, model: BrightnessModel = BrightnessModel(), *,
                min_contrast: float = 0.3) -> tuple[TrackResult, BrightnessModel]:
    """Find a bright bar of the stripe's width in `win` of `image`'s blue band; return the result and the updated model."""
    pix, inside = win.extract(image)
    blue = pix[..., 2].astype(np.float32)
    profile = np.where(inside, blue, np.nan)
    n = inside.sum(axis=0)
    prof = np.where(n > 0, np.nansum(profile, axis=0) / np.maximum(n, 1), np.nan)
    valid = np.isfinite(prof)
    if valid.sum() < 5:
        return TrackResult(status="clipped"), model
    prof = np.where(valid, prof, np.nanmedian(prof))
    b = max(int(round(stripe_width_m * win.px_per_m)), 1)
    if len(prof) < 3 * b + 2:
        return TrackResult(status="missing"), model
    # a bar, not an edge: the bar must stand above both flanks (a shadow edge has one bright flank)
    box = np.convolve(prof, np.ones(b) / b, mode="valid")  # box[i]: mean of prof[i : i + b]
    bar, left, right = box[b:len(box) - b], box[:len(box) - 2 * b], box[2 * b:]
    corr = bar - np.maximum(left, right)  # bar centred at j + 1.5b - 0.5
    j = int(np.argmax(corr))
    background = float(np.median(prof))
    contrast = float(corr[j])
    shifted = model.background is not None and not (0.55 < background / max(model.background, 1.0) < 1.8)
    if contrast < min_contrast * max(background, 10.0):
        return TrackResult(status="illumination_shift" if shifted else "missing", score=contrast), model.updated(background)
    centre = j + 1.5 * b - 0.5
    if 0 < j < len(corr) - 1:
        a, c0, c = corr[j - 1], corr[j], corr[j + 1]
        den = a - 2 * c0 + c
        if den < 0:
            centre += 0.5 * (a - c) / den
    if j == 0 or j == len(corr) - 1 or not inside[:, int(np.clip(round(centre), 0, inside.shape[1] - 1))].all():
        return TrackResult(status="clipped", score=contrast), model.updated(background)
    u, v = win.to_image((len(win.rows) - 1) / 2.0, centre)
    return TrackResult(status="found", uv=(u, v), score=contrast), model.updated(background)
