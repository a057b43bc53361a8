"""SE(2) poses (x [m], y [m], yaw [rad]) of a child frame in its parent: the one geometry kernel.

One algebra, written once on `SE2` tuples (`compose_tuple`, `inverse_tuple`, `between_tuple`, `interpolate_tuple`;
the blackboard's frame tree composes these), with two thin forms over it: functions on (3,) float64
arrays for the numeric cores (`compose`, `inverse`, `between`), and `Pose2D`, a frozen model for
messages and APIs. Inverse pairs: `compose` / `between`, `transform_points` (child → parent) /
`inverse_transform_points` (parent → child), `Pose2D.apply` / `Pose2D.apply_inverse`.

One angle wrap, `wrap_angle`, into [-pi, pi) as `(a + pi) mod 2pi - pi`: the definition the kernel, the
simulator and the filters used before it replaced the other wraps (an angle already in range may come
back changed in its last bits, by at most half an ulp of pi, 2.3e-16 rad).

A message type that carries a pose in fields of its own (a token, an EDDIE message, the truth) keeps
its wire format and converts through one named pair, `to_pose2d()` / `from_pose2d(pose, ...)` (the
`PoseFields` mixin), never with algebra of its own.
"""

from __future__ import annotations

import math
from typing import Any, Sequence, TypeVar, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "SE2", "IDENTITY", "Pose2D", "PoseFields", "wrap_angle",
    "compose_tuple", "inverse_tuple", "between_tuple", "interpolate_tuple",
    "compose", "inverse", "between", "transform_points", "inverse_transform_points",
]

#: (x [m], y [m], yaw [rad]) of a child frame in its parent
SE2 = tuple[float, float, float]
#: the pose of a frame in itself
IDENTITY: SE2 = (0.0, 0.0, 0.0)
_TWO_PI = 2.0 * math.pi

_A = TypeVar("_A", float, np.ndarray)


def wrap_angle(a: _A) -> _A:
    """Wrap an angle [rad] (a float, or an array elementwise) into [-pi, pi)."""
    return (a + math.pi) % _TWO_PI - math.pi


def compose_tuple(a: Sequence[float], b: Sequence[float]) -> SE2:
    """Return a∘b: pose b (given in a's child frame) expressed in a's parent frame."""
    ax, ay, ath = a
    bx, by, bth = b
    c, s = math.cos(ath), math.sin(ath)
    return (ax + c * bx - s * by, ay + s * bx + c * by, wrap_angle(ath + bth))


def inverse_tuple(a: Sequence[float]) -> SE2:
    """Return the inverse pose a⁻¹ (child←parent given parent←child)."""
    ax, ay, ath = a
    c, s = math.cos(ath), math.sin(ath)
    return (-(c * ax + s * ay), -(-s * ax + c * ay), wrap_angle(-ath))


def between_tuple(a: Sequence[float], b: Sequence[float]) -> SE2:
    """Return a⁻¹∘b: the motion from pose a to pose b, in a's frame (undoes `compose_tuple(a, ·)`)."""
    return compose_tuple(inverse_tuple(a), b)


def interpolate_tuple(a: Sequence[float], b: Sequence[float], f: float) -> SE2:
    """Return the pose a fraction `f` [-] of the way from a to b: linear in x, y, along the shorter arc in yaw."""
    yaw = a[2] + f * wrap_angle(b[2] - a[2])
    return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), wrap_angle(yaw))


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return a∘b: pose b (given in a's child frame) expressed in a's parent frame; shape (3,) float64."""
    return np.array(compose_tuple(a, b))


def inverse(a: np.ndarray) -> np.ndarray:
    """Return the inverse pose a⁻¹ (child←parent given parent←child); shape (3,) float64."""
    return np.array(inverse_tuple(a))


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return a⁻¹∘b: the motion from pose a to pose b, in a's frame (undoes `compose(a, ·)`); shape (3,) float64."""
    return np.array(between_tuple(a, b))


def transform_points(pose: Sequence[float], pts: np.ndarray) -> np.ndarray:
    """Map points (N,2) float64 [m] from pose's child frame to its parent frame; returns (N,2) float64."""
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    tx, ty, th = float(pose[0]), float(pose[1]), float(pose[2])
    c, s = math.cos(th), math.sin(th)
    out = np.empty_like(pts)
    x, y = pts[:, 0], pts[:, 1]
    np.multiply(x, c, out=out[:, 0])
    out[:, 0] -= s * y
    out[:, 0] += tx
    np.multiply(x, s, out=out[:, 1])
    out[:, 1] += c * y
    out[:, 1] += ty
    return out


def inverse_transform_points(pose: Sequence[float], pts: np.ndarray) -> np.ndarray:
    """Map points (N,2) float64 [m] from pose's parent frame to its child frame (undoes `transform_points`)."""
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    c, s = math.cos(float(pose[2])), math.sin(float(pose[2]))
    dx, dy = pts[:, 0] - float(pose[0]), pts[:, 1] - float(pose[1])
    out = np.empty_like(pts)
    np.multiply(dx, c, out=out[:, 0])
    out[:, 0] += s * dy
    np.multiply(dy, c, out=out[:, 1])
    out[:, 1] -= s * dx
    return out


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
        """Return the pose of a (3,) array or tuple (x [m], y [m], yaw [rad])."""
        return cls(x=float(a[0]), y=float(a[1]), yaw=float(a[2]))

    def compose(self, other: "Pose2D") -> "Pose2D":
        """Return self ∘ other (parent←child composed with child←grandchild)."""
        return Pose2D.from_array(compose_tuple(self.as_tuple(), other.as_tuple()))

    def between(self, other: "Pose2D") -> "Pose2D":
        """Return self⁻¹ ∘ other (undoes `compose`: `self.compose(self.between(o)) == o`)."""
        return Pose2D.from_array(between_tuple(self.as_tuple(), other.as_tuple()))

    def inverse(self) -> "Pose2D":
        """Return the inverse pose (child←parent)."""
        return Pose2D.from_array(inverse_tuple(self.as_tuple()))

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Map (N,2) float64 points [m] from the child frame into the parent frame."""
        return transform_points(self.as_tuple(), points)

    def apply_inverse(self, points: np.ndarray) -> np.ndarray:
        """Map (N,2) float64 points [m] from the parent frame into the child frame (undoes `apply`)."""
        return inverse_transform_points(self.as_tuple(), points)

    def as_tuple(self) -> SE2:
        """Return (x [m], y [m], yaw [rad])."""
        return (self.x, self.y, self.yaw)

    def as_array(self) -> np.ndarray:
        """Return the pose as a (3,) float64 array."""
        return np.array([self.x, self.y, self.yaw])


_P = TypeVar("_P", bound="PoseFields")


class PoseFields:
    """Mixin of a message whose fields x [m], y [m], yaw [rad] are an SE(2) pose: its conversion pair with `Pose2D`.

    A type that stores the pose otherwise (yaw in degrees, say) overrides both, so the pair stays the one
    way in and out.
    """

    __slots__ = ()

    def to_pose2d(self) -> Pose2D:
        """Return this message's pose."""
        return Pose2D(x=self.x, y=self.y, yaw=self.yaw)  # type: ignore[attr-defined]

    @classmethod
    def from_pose2d(cls: type[_P], pose: Union[Pose2D, Sequence[float], np.ndarray], **fields: Any) -> _P:
        """Return a message holding `pose` (a Pose2D, or (x [m], y [m], yaw [rad]) as a (3,) array or tuple) and `fields`."""
        x, y, yaw = pose.as_tuple() if isinstance(pose, Pose2D) else (float(pose[0]), float(pose[1]), float(pose[2]))
        return cls(x=x, y=y, yaw=yaw, **fields)  # type: ignore[call-arg]
