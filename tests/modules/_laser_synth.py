"""Synthetic ERIM-like range images of flat ground and boxes, cast analytically (for the laser library tests)."""

from __future__ import annotations

import math

import numpy as np

from modules.perception.obstacles import LaserScan

__all__ = ["synthetic_scan"]

_T = np.eye(4)
_T[:3, 3] = (1.6, 0.0, 2.3)  # the Navlab's scanner mount, `vehicle` ← `laser`


def synthetic_scan(boxes: list[tuple[float, float, float, float, float]], *, stamp: float = 0.0,
                   cols: int = 256, rows: int = 64, ambiguity: float = 20.48) -> LaserScan:
    """Return a noise-free scan of the plane z = 0 and axis-aligned boxes (x0, x1, y0, y1, height) [m], `vehicle` frame."""
    az = np.deg2rad(np.linspace(40, -40, cols)).astype(np.float32)
    el = np.deg2rad(np.linspace(1, -29, rows)).astype(np.float32)
    ce = np.cos(el)[:, None].astype(np.float64)
    d = np.stack([ce * np.cos(az)[None], ce * np.sin(az)[None], np.broadcast_to(np.sin(el)[:, None], (rows, cols))], -1)
    o = _T[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(d[..., 2] < 0, -o[2] / d[..., 2], np.inf)
        for x0, x1, y0, y1, h in boxes:  # slab intersection
            tn = np.full(r.shape, -np.inf)
            tf = np.full(r.shape, np.inf)
            for k, (lo, hi) in enumerate(((x0, x1), (y0, y1), (0.0, h))):
                a = (lo - o[k]) / d[..., k]
                b = (hi - o[k]) / d[..., k]
                tn = np.maximum(tn, np.minimum(a, b))
                tf = np.minimum(tf, np.maximum(a, b))
            hit = (tn <= tf) & (tn > 0)
            r = np.where(hit & (tn < r), tn, r)
    valid = np.isfinite(r) & (r < 40.0)
    wrapped = np.mod(np.where(valid, r, 0.0), ambiguity).astype(np.float32)
    refl = np.full(r.shape, 120, np.uint8)
    return LaserScan(range_m=wrapped, valid=valid, az=az, el=el, T_vehicle_laser=_T.copy(), ambiguity=ambiguity, stamp=stamp,
                     reflectance=refl)


def rotate(points: np.ndarray, yaw: float) -> np.ndarray:
    """Return (N, 2) points rotated by yaw [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    return points @ np.array([[c, s], [-s, c]])
