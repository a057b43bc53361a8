"""YARF's road spine (Navlab 1990 §2.2.2 "Road Geometry", §5.4): a parabola fitted to the features seen.

The spine is locally a circular arc on flat ground, approximated by the seed's parabola
`x = ½c·y² + s·y + o` with y along the road; here in `vehicle` axes (x forward, y left) it reads
`y = ½c·x² + s·x + o`: `o` the lateral offset [m] at the vehicle, `s` the slope (tan of the heading),
`c` the curvature [1/m]. The least-squares fit is the pseudo-inverse; the robust fit is an
M-estimate (Tukey's biweight by iteratively reweighted least squares, scale from the median
absolute residual) that gives outliers zero weight and reports them.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict

__all__ = ["Spine", "SpineFit", "fit_spine_lsq", "fit_spine_robust"]


class Spine(BaseModel):
    """The road spine y = ½c·x² + s·x + o in `vehicle`: curvature c [1/m], slope s [-], offset o [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    curvature: float = 0.0
    slope: float = 0.0
    offset: float = 0.0

    def lateral(self, x: np.ndarray | float) -> np.ndarray | float:
        """Return the spine's y [m] at x [m] ahead (`vehicle`)."""
        x = np.asarray(x, float)
        return 0.5 * self.curvature * x * x + self.slope * x + self.offset


class SpineFit(BaseModel):
    """A fitted spine, which points were inliers, and the robust residual scale [m]."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    spine: Spine
    inliers: np.ndarray  # (N,) bool
    scale_m: float


def _design(x: np.ndarray) -> np.ndarray:
    return np.stack([0.5 * x * x, x, np.ones_like(x)], axis=1)


def fit_spine_lsq(x: np.ndarray, y: np.ndarray, weights: np.ndarray | None = None,
                  curvature_prior: tuple[float, float] | None = None) -> Spine:
    """Return the (weighted) least-squares spine through points (x, y) [m] by the pseudo-inverse.

    `curvature_prior` (c0 [1/m], sigma [1/m]) adds one pseudo-observation c = c0 worth a 0.1 m residual
    per `sigma` (the road's curvature changes slowly from frame to frame).
    """
    a = _design(np.asarray(x, float))
    b = np.asarray(y, float)
    if weights is not None:
        w = np.sqrt(np.asarray(weights, float))
        a, b = a * w[:, None], b * w
    if curvature_prior is not None:
        k = 0.1 / curvature_prior[1]
        a = np.vstack([a, [k, 0.0, 0.0]])
        b = np.append(b, k * curvature_prior[0])
    c, s, o = np.linalg.pinv(a) @ b
    return Spine(curvature=float(c), slope=float(s), offset=float(o))


def fit_spine_robust(x: np.ndarray, y: np.ndarray, *, tuning: float = 4.685, min_scale_m: float = 0.05,
                     iterations: int = 12, curvature_prior: tuple[float, float] | None = None) -> SpineFit:
    """Return the M-estimate of the spine (Tukey biweight); points with zero final weight are outliers."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    spine = fit_spine_lsq(x, y, curvature_prior=curvature_prior)
    w = np.ones(len(x))
    scale = min_scale_m
    for it in range(iterations):
        r = y - spine.lateral(x)
        scale = max(1.4826 * float(np.median(np.abs(r - np.median(r)))), min_scale_m)
        if it < iterations // 2:
            # Huber first (convex, so the start cannot be captured by the outliers), then the biweight
            a = np.abs(r) / (1.345 * scale)
            w = np.where(a <= 1.0, 1.0, 1.0 / np.maximum(a, 1e-12))
        else:
            u = r / (tuning * scale)
            w = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        if (w > 0).sum() < 3:
            break
        spine = fit_spine_lsq(x, y, w, curvature_prior)
    return SpineFit(spine=spine, inliers=w > 0.0, scale_m=scale)
