"""Pure run metrics: distance, cross-track error, position error against the truth."""

from __future__ import annotations

import numpy as np
from shapely import LineString, points as shp_points

__all__ = [
    "path_length",
    "cross_track_errors",
    "position_errors",
    "interpolate_track",
]


def path_length(xy: np.ndarray) -> float:
    """Return the length of a polyline (N,2) [m]."""
    xy = np.asarray(xy, dtype=float)
    if len(xy) < 2:
        return 0.0
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T)))


def cross_track_errors(xy: np.ndarray, route: np.ndarray) -> np.ndarray:
    """Return the distance of each point (N,2) to the route polyline (M,2), both in `world` [m]."""
    xy = np.asarray(xy, dtype=float)
    if len(xy) == 0 or len(route) < 2:
        return np.zeros(0)
    line = LineString(np.asarray(route, dtype=float))
    return np.asarray(line.distance(shp_points(xy)), dtype=float)


def interpolate_track(t_query: np.ndarray, t: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Return a track (t (N,) [s], xy (N,2) [m]) linearly interpolated at t_query (K,) [s]."""
    t = np.asarray(t, dtype=float)
    xy = np.asarray(xy, dtype=float)
    return np.column_stack([np.interp(t_query, t, xy[:, 0]), np.interp(t_query, t, xy[:, 1])])


def position_errors(t_est: np.ndarray, xy_est: np.ndarray, t_true: np.ndarray, xy_true: np.ndarray) -> np.ndarray:
    """Return |estimate − truth| [m] at the estimate's stamps, the truth interpolated in time.

    Estimates stamped outside the truth's time span are dropped.
    """
    t_est = np.asarray(t_est, dtype=float)
    t_true = np.asarray(t_true, dtype=float)
    if len(t_est) == 0 or len(t_true) < 2:
        return np.zeros(0)
    keep = (t_est >= t_true[0]) & (t_est <= t_true[-1])
    truth = interpolate_track(t_est[keep], t_true, xy_true)
    return np.hypot(*(np.asarray(xy_est, dtype=float)[keep] - truth).T)
