"""SE(2) pose algebra on numpy arrays (x [m], y [m], yaw [rad]) used by the PILOT's pure cores."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["wrap_angle", "compose", "inverse", "between", "transform_points"]


def wrap_angle(a: float) -> float:
    """Wrap an angle [rad] into [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return a∘b: pose b (given in a's child frame) expressed in a's parent frame; shape (3,)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap_angle(a[2] + b[2])])


def inverse(a: np.ndarray) -> np.ndarray:
    """Return the inverse pose a⁻¹ (child←parent given parent←child); shape (3,)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([-c * a[0] - s * a[1], s * a[0] - c * a[1], wrap_angle(-a[2])])


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return a⁻¹∘b: the motion from pose a to pose b, in a's frame; shape (3,)."""
    return compose(inverse(a), b)


def transform_points(pose: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Map points (N,2) float64 from pose's child frame to its parent frame; returns (N,2)."""
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    return pts @ rot.T + np.asarray(pose[:2], dtype=np.float64)
