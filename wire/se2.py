"""SE(2) poses (x [m], y [m], yaw [rad]) of a child frame in its parent, with named inverse pairs.

Two forms of one algebra: `Pose2D`, a frozen model for messages and APIs, and functions on (3,)
float64 arrays for the pure numeric cores. Inverse pairs: `compose` / `between`,
`transform_points` (child → parent) / `inverse_transform_points` (parent → child),
`Pose2D.apply` / `Pose2D.apply_inverse`. Angles are wrapped into [-pi, pi).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "Pose2D", "wrap_angle", "compose", "inverse", "between", "transform_points", "inverse_transform_points",
]


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
    """Return a⁻¹∘b: the motion from pose a to pose b, in a's frame (undoes `compose(a, ·)`); shape (3,)."""
    return compose(inverse(a), b)


def transform_points(pose: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Map points (N,2) float64 from pose's child frame to its parent frame; returns (N,2)."""
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    return pts @ rot.T + np.asarray(pose[:2], dtype=np.float64)


def inverse_transform_points(pose: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Map points (N,2) float64 from pose's parent frame to its child frame (undoes `transform_points`)."""
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2) - np.asarray(pose[:2], dtype=np.float64)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rot = np.array([[c, -s], [s, c]])
    return pts @ rot


class Pose2D(BaseModel):
    """An SE(2) pose: translation (x [m], y [m]) and heading yaw [rad] of a child frame in its parent."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    x: float = Field(0.0, allow_inf_nan=False)
    y: float = Field(0.0, allow_inf_nan=False)
    yaw: float = Field(0.0, allow_inf_nan=False)

    def __init__(self, x: float | None = None, y: float | None = None, yaw: float | None = None, /, **kw: Any) -> None:
        for name, v in (("x", x), ("y", y), ("yaw", yaw)):
            if v is not None:
                kw[name] = v
        super().__init__(**kw)

    @classmethod
    def from_array(cls, a: Any) -> "Pose2D":
        """Return the pose of a (3,) array (x [m], y [m], yaw [rad])."""
        return cls(x=float(a[0]), y=float(a[1]), yaw=float(a[2]))

    def compose(self, other: "Pose2D") -> "Pose2D":
        """Return self ∘ other (parent←child composed with child←grandchild)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(
            x=self.x + c * other.x - s * other.y,
            y=self.y + s * other.x + c * other.y,
            yaw=math.atan2(math.sin(self.yaw + other.yaw), math.cos(self.yaw + other.yaw)),
        )

    def between(self, other: "Pose2D") -> "Pose2D":
        """Return self⁻¹ ∘ other (undoes `compose`: `self.compose(self.between(o)) == o`)."""
        return self.inverse().compose(other)

    def inverse(self) -> "Pose2D":
        """Return the inverse pose (child←parent)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(x=-(c * self.x + s * self.y), y=-(-s * self.x + c * self.y), yaw=-self.yaw)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Map (N,2) float64 points [m] from the child frame into the parent frame."""
        return transform_points(np.array([self.x, self.y, self.yaw]), points)

    def apply_inverse(self, points: np.ndarray) -> np.ndarray:
        """Map (N,2) float64 points [m] from the parent frame into the child frame (undoes `apply`)."""
        return inverse_transform_points(np.array([self.x, self.y, self.yaw]), points)

    def as_tuple(self) -> tuple[float, float, float]:
        """Return (x [m], y [m], yaw [rad])."""
        return (self.x, self.y, self.yaw)

    def as_array(self) -> np.ndarray:
        """Return the pose as a (3,) float64 array."""
        return np.array([self.x, self.y, self.yaw])
