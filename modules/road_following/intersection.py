"""SCARF's intersection detection (Navlab 1990 §1.2.1): the search decomposed, main road first, then branches.

Once pixels are classified and the main road found (a 2-D search, `triangle_road`), the biggest
branch is searched in 2-D (where along the main road it leaves, and at what angle); further
branches must leave at the same point, so each is a 1-D search over the angle. A candidate is a
road-shaped region — a strip of the road width, on the ground, from the main road's edge outwards —
accepted when the mean road probability of its pixels exceeds 0.5; the search stops when no
candidate is good enough. Everything is on the ground in `vehicle` [m], from the pixels' ground points.
"""

from __future__ import annotations

import math

import numpy as np

from modules.road_following.follower import Branch
from wire.se2 import wrap_angle

__all__ = ["find_branches"]


def _strip(g: np.ndarray, origin: np.ndarray, angle: float, half_width: float, start: float, length: float) -> np.ndarray:
    """Return which ground points `g` (N, 2) lie in a strip from `origin` at `angle` [rad]: along ∈ [start, length], |across| ≤ half_width."""
    u = np.array([math.cos(angle), math.sin(angle)])
    d = g - origin
    along = d @ u
    across = d @ np.array([-u[1], u[0]])
    return (along >= start) & (along <= length) & (np.abs(across) <= half_width)


def find_branches(p_road: np.ndarray, ground: np.ndarray, lateral_m: float, heading_rad: float, road_width_m: float, *,
                  along_m: np.ndarray | None = None, angles_rad: np.ndarray | None = None, length_m: float = 18.0,
                  min_pixels: int = 25, accept: float = 0.5, max_branches: int = 3) -> tuple[Branch, ...]:
    """Return the branch roads leaving the main road (lateral [m], heading [rad] in `vehicle`), best first.

    `p_road` (H, W) road probability and `ground` (H, W, 2) the pixels' ground points (NaN: sky).
    """
    ok = np.isfinite(ground[..., 0]) & np.isfinite(ground[..., 1])
    g = ground[ok].astype(np.float64)
    p = p_road[ok].astype(np.float64)
    if len(g) == 0:
        return ()
    if along_m is None:
        along_m = np.arange(max(6.0, float(np.nanmin(g[:, 0]))), 40.0, 1.5)
    if angles_rad is None:
        angles_rad = np.radians(np.concatenate([np.arange(30.0, 151.0, 10.0), -np.arange(30.0, 151.0, 10.0)]))
    h = road_width_m / 2.0
    u = np.array([math.cos(heading_rad), math.sin(heading_rad)])
    start_pt = np.array([0.0, lateral_m])
    main = _strip(g, start_pt, heading_rad, h, -1e3, 1e3)
    free = ~main

    def score(origin: np.ndarray, angle: float, taken: np.ndarray) -> tuple[float, np.ndarray]:
        m = _strip(g, origin, heading_rad + angle, h, h, length_m) & free & ~taken
        if m.sum() < min_pixels:
            return 0.0, m
        return float(p[m].mean()), m

    taken = np.zeros(len(g), bool)
    best = (0.0, 0.0, 0.0, None)
    for s in along_m:
        origin = start_pt + u * s
        for a in angles_rad:
            sc, m = score(origin, float(a), taken)
            if sc > best[0]:
                best = (sc, float(s), float(a), m)
    if best[0] <= accept or best[3] is None:
        return ()
    out = [Branch(along_m=best[1], angle_rad=best[2], probability=min(best[0], 1.0))]
    taken |= best[3]
    origin = start_pt + u * best[1]
    while len(out) < max_branches:
        cand = (0.0, 0.0, None)
        for a in angles_rad:
            if min(abs(wrap_angle(float(a) - b.angle_rad)) for b in out) < math.radians(40.0):
                continue
            sc, m = score(origin, float(a), taken)
            if sc > cand[0]:
                cand = (sc, float(a), m)
        if cand[0] <= accept or cand[2] is None:
            break
        out.append(Branch(along_m=best[1], angle_rad=cand[1], probability=min(cand[0], 1.0)))
        taken |= cand[2]
    return tuple(out)
