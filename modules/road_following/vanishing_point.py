"""The vanishing-point Hough (Navlab 1990 §5.5, Figure 5.6): road features found without a prediction.

The features of a straight road are parallel lines on the ground, which meet in the image at one
vanishing point on the horizon row. A curved road is taken straight within each of a few horizontal
bands of the image. A line is (vp, θ): the column where it crosses the horizon row and its angle
with the image rows. Each edge point (Sobel magnitude above a threshold) at (row, col) with edge
direction φ votes, for every vanishing point vp, for the one line through both, θ =
atan((row − horizon) / (col − vp)), with weight 1 − diff / 90, diff the angle [deg] between θ and φ
(the paper's "edge gradient estimate": the direction along the edge, square to the gradient). A
line's votes are divided by its visible length in the band, so lines near the image's corners are
not short-changed. Per band the accumulator is thresholded, its peaks found, and the peaks through
each vanishing point summed into its support; the three best vanishing points of every band then
compete in a global search whose criterion adds their supports and rewards features that carry on
from one band into the next (continuity at the rows bands share).

The single-band image is the blue band (a yellow line is dark in it, a white one bright). Thresholds
the paper leaves open are named below. Rows and columns are pixels of the image given, row 0 at the top.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from modules.road_following.errors import RoadFollowingError

__all__ = ["VanishingConfig", "BandLines", "vanishing_lines", "edge_points"]


@dataclass(frozen=True)
class VanishingConfig:
    """The Hough's settings: bands, edge threshold, the vote grids, peaks and the global search."""

    bands: int = 5  # horizontal bands below the horizon (the paper: four to seven)
    top_gap: float = 0.3  # the bands start this share of (image height − horizon) below the horizon (beyond, the road is a few pixels wide)
    edge_threshold: float = 60.0  # Sobel 3×3 magnitude of the blue band [DN]: a 15 DN step
    max_diff_deg: float = 20.0  # points vote only for lines within this of their edge direction (weight ≥ 0.78)
    min_theta_deg: float = 12.0  # lines closer to the rows than this are not road features (tree lines, shadow edges)
    min_visible: float = 0.6  # a line must cross this share of its band's rows inside the image
    vp_step_px: float = 1.0  # vanishing-point columns, from −W/2 to 3W/2 (roads within about ±60° of the camera's axis)
    theta_step_deg: float = 1.0
    peak_min: float = 0.25  # a peak holds at least this many votes per pixel of visible line
    peak_window: int = 5  # peaks are maxima of a window this wide (bins)
    vp_tolerance_px: float = 4.0  # peaks within this of a vanishing point support it
    candidates: int = 3  # vanishing points per band in the global search
    continuity_px: float = 3.0  # lines of adjacent bands within this at their shared row carry on
    continuity_weight: float = 0.5  # the criterion: Σ supports (each band's best = 1) + this × Σ lines carried on


@dataclass(frozen=True)
class BandLines:
    """One band's choice: rows [r0, r1), vanishing point column [px] and support, lines as (vp, θ [rad], strength)."""

    rows: tuple[int, int]
    vp: float
    support: float
    lines: tuple[tuple[float, float, float], ...]

    def column_at(self, theta: float, row: float, horizon: float) -> float:
        """Return the column [px] of this band's line of angle `theta` [rad] at `row` [px]."""
        return self.vp + (row - horizon) / math.tan(theta)


def edge_points(band: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Return the edge points of a single-band image (H, W): rows, columns, magnitudes and edge directions [rad, 0–π]."""
    b = band.astype(np.float32)
    gx = cv2.Sobel(b, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(b, cv2.CV_32F, 0, 1, ksize=3)
    mag = np.hypot(gx, gy)
    r, c = np.nonzero(mag > threshold)
    # along the edge: square to the gradient; with rows down, a line going down-right has θ in (0, π/2)
    phi = np.mod(np.arctan2(gy[r, c], gx[r, c]) + math.pi / 2.0, math.pi)
    return r, c, mag[r, c], phi


def _visible_length(vps: np.ndarray, thetas: np.ndarray, r0: int, r1: int, horizon: float, width: int) -> np.ndarray:
    """Return the length [px] of each line (vp, θ) inside rows [r0, r1) and columns [0, width), (V, T)."""
    cot = 1.0 / np.tan(thetas)[None, :]
    c0 = vps[:, None] + (r0 - horizon) * cot
    c1 = vps[:, None] + (r1 - horizon) * cot
    lo, hi = np.minimum(c0, c1), np.maximum(c0, c1)
    span = np.maximum(hi - lo, 1e-9)
    inside = np.clip((np.minimum(hi, width - 1.0) - np.maximum(lo, 0.0)) / span, 0.0, 1.0)
    inside = np.where(hi - lo < 1e-6, ((lo >= 0) & (lo <= width - 1)).astype(float), inside)
    return inside * (r1 - r0) / np.sin(thetas)[None, :]


def _band_accumulator(r, c, phi, vps, thetas, horizon, cfg: VanishingConfig) -> np.ndarray:
    """Return the votes (V, T) of the band's edge points for every line (vp, θ)."""
    acc = np.zeros((len(vps), len(thetas)))
    if len(r) == 0:
        return acc
    dr = (r - horizon).astype(np.float64)[None, :]
    th = np.arctan2(dr, c[None, :] - vps[:, None])  # (V, P) in (0, π): the line through the point and each vp
    diff = np.abs(th - phi[None, :])
    diff = np.degrees(np.minimum(diff, math.pi - diff))
    w = 1.0 - diff / 90.0
    ok = diff <= cfg.max_diff_deg
    ti = np.clip(np.round((th - thetas[0]) / (thetas[1] - thetas[0])).astype(np.int64), 0, len(thetas) - 1)
    vi = np.broadcast_to(np.arange(len(vps))[:, None], th.shape)
    np.add.at(acc, (vi[ok], ti[ok]), w[ok])
    return acc


def _peaks(acc: np.ndarray, cfg: VanishingConfig) -> tuple[np.ndarray, np.ndarray]:
    """Return the (vp, θ) indices of the accumulator's peaks: window maxima of at least `peak_min`."""
    k = cfg.peak_window
    m = cv2.dilate(acc.astype(np.float32), np.ones((k, k), np.uint8))
    vi, ti = np.nonzero((acc.astype(np.float32) >= m) & (acc >= cfg.peak_min))
    return vi, ti


def vanishing_lines(band_image: np.ndarray, horizon: float, cfg: VanishingConfig = VanishingConfig()) -> tuple[BandLines, ...]:
    """Return, nearest band last, each band's vanishing point and lines in the single-band image (H, W) (see the module docstring)."""
    h, w = band_image.shape
    if not 0 <= horizon < h - cfg.bands:
        raise RoadFollowingError(f"vanishing point Hough: horizon row {horizon:.1f} leaves no bands in a {h}-row image")
    top = int(math.ceil(horizon + cfg.top_gap * (h - horizon)))
    cuts = np.linspace(top, h, cfg.bands + 1).round().astype(int)
    vps = np.arange(-w / 2.0, 1.5 * w, cfg.vp_step_px, dtype=np.float64)
    thetas = np.radians(np.arange(cfg.min_theta_deg, 180.0 - cfg.min_theta_deg + 1e-9, cfg.theta_step_deg))
    r, c, _, phi = edge_points(band_image, cfg.edge_threshold)
    steep = np.abs(phi - math.pi / 2.0) <= math.radians(90.0 - cfg.min_theta_deg)  # edges along the rows are no road features
    r, c, phi = r[steep], c[steep], phi[steep]
    options: list[list[tuple[float, float, list[tuple[float, float, float]]]]] = []
    for b in range(cfg.bands):
        r0, r1 = int(cuts[b]), int(cuts[b + 1])
        sel = (r >= r0) & (r < r1)
        acc = _band_accumulator(r[sel], c[sel], phi[sel], vps, thetas, horizon, cfg)
        length = _visible_length(vps, thetas, r0, r1, horizon, w)
        acc = np.where(length >= cfg.min_visible * (r1 - r0), acc / np.maximum(length, 1.0), 0.0)
        vi, ti = _peaks(acc, cfg)
        cands: list[tuple[float, float, list[tuple[float, float, float]]]] = []
        strength = acc[vi, ti]
        for order in np.argsort(-strength):
            if len(cands) >= cfg.candidates:
                break
            v = vps[vi[order]]
            if any(abs(v - cv) <= cfg.vp_tolerance_px for cv, _, _ in cands):
                continue
            near = np.abs(vps[vi] - v) <= cfg.vp_tolerance_px
            lines = [(float(vps[a]), float(thetas[t]), float(acc[a, t])) for a, t in zip(vi[near], ti[near])]
            cands.append((float(v), float(sum(s for _, _, s in lines)), lines))
        options.append(cands or [(float("nan"), 0.0, [])])
    best_support = [max(s for _, s, _ in o) or 1.0 for o in options]

    def carried(b: int, up: tuple, down: tuple) -> int:
        row = float(cuts[b + 1])
        cols_up = [u[0] + (row - horizon) / math.tan(u[1]) for u in up[2]]
        cols_down = [d[0] + (row - horizon) / math.tan(d[1]) for d in down[2]]
        return sum(1 for cu in cols_up if any(abs(cu - cd) <= cfg.continuity_px for cd in cols_down))

    best, best_score = None, -math.inf
    for pick in itertools.product(*options):
        score = sum(p[1] / s for p, s in zip(pick, best_support))
        score += cfg.continuity_weight * sum(carried(b, pick[b], pick[b + 1]) for b in range(cfg.bands - 1))
        if score > best_score:
            best, best_score = pick, score
    assert best is not None
    return tuple(BandLines(rows=(int(cuts[b]), int(cuts[b + 1])), vp=p[0], support=p[1], lines=tuple(p[2])) for b, p in enumerate(best))
