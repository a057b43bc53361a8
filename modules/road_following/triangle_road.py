"""SCARF's road model and vote (Navlab 1990 §2.2.1, §4.4.2.3 "Road Hough"): a triangle in the image.

The road is a triangle whose apex lies on the horizon row and whose base has a fixed width set by
the road width and the camera: the half width grows by `k` pixels per row below the horizon. Two
free parameters: the apex column `v` and the skew `theta` of the centre line from vertical, the
centre at row r being at column v − (r − horizon)·tan θ. Every pixel votes for all (v, θ) whose
triangle contains it, weighted by how sure its classification is (P(road) − P(off-road)), as the
seed's interval v_s … v_e for each θ. The cell with the most votes is the road.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict

from modules.road_following.camera import CameraGeometry

__all__ = ["TriangleRoad", "half_width_rate", "vote", "best_triangle", "triangle_mask", "triangle_in_vehicle"]


class TriangleRoad(BaseModel):
    """A triangle road in one image: apex column [px] on the horizon row [px], skew [rad], half-width rate [px/row], votes."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    apex_col: float
    skew_rad: float
    horizon_row: float
    half_width_rate: float
    votes: float = 0.0

    def centre_col(self, row: np.ndarray | float) -> np.ndarray | float:
        """Return the centre column [px] at image row(s) `row` [px]."""
        return self.apex_col - (np.asarray(row, float) - self.horizon_row) * math.tan(self.skew_rad)


def half_width_rate(camera: CameraGeometry, road_width_m: float) -> float:
    """Return how many pixels the road's half width grows per row below the horizon (flat, straight road)."""
    x = np.array([8.0, 20.0])
    u_l, v, _ = camera.project_ground(np.stack([x, np.full(2, road_width_m / 2)], -1))
    u_r, _, _ = camera.project_ground(np.stack([x, np.full(2, -road_width_m / 2)], -1))
    return float(np.mean((u_r - u_l) / 2.0 / (v - camera.horizon_row)))


def vote(weight: np.ndarray, horizon_row: float, k: float, apex_cols: np.ndarray, skews: np.ndarray) -> np.ndarray:
    """Return the accumulator (len(skews), len(apex_cols)) of the pixels' votes `weight` (H, W) for every triangle.

    `apex_cols` must be evenly spaced; only pixels below the horizon vote.
    """
    h, w = weight.shape
    r0 = int(math.floor(horizon_row)) + 1
    rows, cols = np.mgrid[r0:h, 0:w]
    dr = (rows - horizon_row).ravel()
    c = cols.ravel().astype(float)
    wt = weight[r0:, :].ravel().astype(float)
    keep = wt != 0.0
    dr, c, wt = dr[keep], c[keep], wt[keep]
    n_v = len(apex_cols)
    step = float(apex_cols[1] - apex_cols[0]) if n_v > 1 else 1.0
    t = np.tan(skews)[:, None]
    base = c[None, :] + dr[None, :] * t  # apex column that puts the centre on this pixel, per skew
    lo = np.ceil((base - k * dr[None, :] - apex_cols[0]) / step).astype(np.int64)
    hi = np.floor((base + k * dr[None, :] - apex_cols[0]) / step).astype(np.int64) + 1
    lo = np.clip(lo, 0, n_v)
    hi = np.clip(hi, 0, n_v)
    off = (np.arange(len(skews)) * (n_v + 1))[:, None]
    ww = np.broadcast_to(wt[None, :], lo.shape).ravel()
    size = len(skews) * (n_v + 1)
    diff = np.bincount((lo + off).ravel(), ww, size) - np.bincount((hi + off).ravel(), ww, size)
    return np.cumsum(diff.reshape(len(skews), n_v + 1), axis=1)[:, :n_v]


def best_triangle(weight: np.ndarray, horizon_row: float, k: float, apex_cols: np.ndarray, skews: np.ndarray) -> TriangleRoad:
    """Return the triangle with the most votes (the road)."""
    acc = vote(weight, horizon_row, k, apex_cols, skews)
    i, j = np.unravel_index(int(np.argmax(acc)), acc.shape)
    return TriangleRoad(apex_col=float(apex_cols[j]), skew_rad=float(skews[i]), horizon_row=horizon_row, half_width_rate=k,
                        votes=float(acc[i, j]))


def triangle_mask(shape: tuple[int, int], road: TriangleRoad, scale: float = 1.0) -> np.ndarray:
    """Return (H, W) bool: pixels inside the triangle whose half width is `scale` × the road's."""
    h, w = shape
    rows, cols = np.mgrid[0:h, 0:w].astype(float)
    dr = rows - road.horizon_row
    return (dr > 0) & (np.abs(cols - road.centre_col(rows)) <= scale * road.half_width_rate * dr)


def triangle_in_vehicle(road: TriangleRoad, camera: CameraGeometry) -> tuple[float, float]:
    """Return the triangle's centre line on the ground: (lateral offset at x = 0 [m], heading [rad]) in `vehicle`."""
    h = camera.height
    rows = np.array([road.horizon_row + 0.45 * (h - 1 - road.horizon_row), h - 1.0])
    xy = camera.ground_points(road.centre_col(rows), rows)
    d = xy[1] - xy[0]
    heading = math.atan2(-d[1], -d[0])  # from the near point to the far one
    lateral = float(xy[1, 1] - xy[1, 0] * math.tan(heading))
    return lateral, heading
