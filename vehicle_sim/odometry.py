"""Wheel odometry with realistic drift: scale error, heading bias, and random-walk noise, seeded.

Per step, from the true travelled arc length ds [m] and true heading change dyaw [rad]:

    ds_m   = (1 + scale_error) · ds + N(0, distance_noise² · |ds|)
    dyaw_m = (1 + yaw_scale_error) · dyaw + heading_bias · |ds| + N(0, heading_noise² · |ds| + turn_noise² · |dyaw|)

so over a straight run of length D the distance error has mean scale_error·D and standard deviation
distance_noise·√D, and the heading error mean heading_bias·D and deviation heading_noise·√D.
The measured increments are integrated in the `local` frame, which starts at (0, 0, 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.kinematics import integrate_arc
from wire.se2 import wrap_angle

__all__ = ["OdometryModel", "OdometryState", "DEFAULT_ODOMETRY", "PERFECT_ODOMETRY", "odometry_step", "NoiseSource"]


class OdometryModel(BaseModel):
    """Odometry error model: scale errors [-], heading bias [rad/m], noise densities [m/√m], [rad/√m], [rad/√rad]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scale_error: float = 0.01
    yaw_scale_error: float = 0.01
    heading_bias: float = 0.0005
    distance_noise: float = Field(default=0.01, ge=0.0)
    heading_noise: float = Field(default=0.001, ge=0.0)
    turn_noise: float = Field(default=0.005, ge=0.0)


DEFAULT_ODOMETRY = OdometryModel()
PERFECT_ODOMETRY = OdometryModel(scale_error=0.0, yaw_scale_error=0.0, heading_bias=0.0, distance_noise=0.0, heading_noise=0.0, turn_noise=0.0)


@dataclass(frozen=True, slots=True)
class OdometryState:
    """Dead-reckoned pose in the local frame: x, y [m], yaw [rad]; odometer [m]; last measured v [m/s], omega [rad/s]."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    distance: float = 0.0
    v: float = 0.0
    omega: float = 0.0


class NoiseSource:
    """Standard normal pairs drawn in blocks from an injected Generator (cheap per step, same stream)."""

    def __init__(self, rng: np.random.Generator, block: int = 4096) -> None:
        self._rng = rng
        self._block = block
        self._buf = np.empty((0, 2))
        self._i = 0

    def pair(self) -> tuple[float, float]:
        """Return two independent N(0, 1) samples."""
        if self._i >= len(self._buf):
            self._buf = self._rng.standard_normal((self._block, 2))
            self._i = 0
        a, b = self._buf[self._i]
        self._i += 1
        return float(a), float(b)


def odometry_step(state: OdometryState, ds: float, dyaw: float, dt: float, model: OdometryModel, noise: tuple[float, float]) -> OdometryState:
    """Integrate one measured increment of the true arc `ds` [m] and turn `dyaw` [rad] over `dt` [s].

    `noise` is a pair of standard normal samples (from a seeded `NoiseSource`).
    """
    ads, adyaw = abs(ds), abs(dyaw)
    ds_m = (1.0 + model.scale_error) * ds + model.distance_noise * math.sqrt(ads) * noise[0]
    sig_yaw = math.sqrt(model.heading_noise ** 2 * ads + model.turn_noise ** 2 * adyaw)
    dyaw_m = (1.0 + model.yaw_scale_error) * dyaw + model.heading_bias * ads + sig_yaw * noise[1]
    x, y, yaw = integrate_arc(state.x, state.y, state.yaw, ds_m, dyaw_m)
    yaw = wrap_angle(yaw)
    return OdometryState(
        x=x, y=y, yaw=yaw, distance=state.distance + abs(ds_m),
        v=ds_m / dt if dt > 0 else 0.0, omega=dyaw_m / dt if dt > 0 else 0.0,
    )
