"""Obstacle features (Navlab 1990 §4.3.1): features the vehicle could not drive over.

"An obstacle was a feature that the vehicle could not drive over — i.e., a feature sufficiently
above ground level." FIDO took the ground to be the plane the vehicle stands on (z = 0 in
`vehicle`), and so do we: a feature is an obstacle when it stands between `min_height` and
`max_height` [m] above that plane (higher ones pass overhead) within `max_distance` [m] of the
vehicle. On sloped ground the plane is wrong, as it was for FIDO.
"""

from __future__ import annotations

import numpy as np

from modules.fido.triangulation import StereoPoints

__all__ = ["obstacle_mask"]


def obstacle_mask(points: StereoPoints, min_height: float = 0.3, max_height: float = 3.0,
                  max_distance: float = 20.0) -> np.ndarray:
    """Return (N,) bool: which triangulated features (`vehicle` frame) are obstacles."""
    xyz = points.xyz
    with np.errstate(invalid="ignore"):
        near = np.hypot(xyz[:, 0], xyz[:, 1]) <= max_distance
        return points.valid & near & (xyz[:, 2] > min_height) & (xyz[:, 2] < max_height)
