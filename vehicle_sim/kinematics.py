"""Vehicle kinematics as pure functions `step(state, command, dt, params) -> state`.

Navlab: an Ackermann (bicycle) van — curvature |κ| ≤ 1/7 m⁻¹ (7 m minimum turning radius, Navlab
1990 §2.4), 28 km/h top speed, first-order actuator lag on speed and steering, acceleration and
steering-rate limits. Terregator: a six-wheel skid-steer vehicle — slow (1 m/s), turns in place,
track speeds limited, first-order lag, acceleration limits.

Frames: the state is the `vehicle` pose in the `world` frame: x, y [m], yaw [rad] CCW from +x.
Motion within a step is integrated exactly along the arc of the step's mean speed and yaw rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Protocol, Union

from pydantic import BaseModel, ConfigDict

from wire.drive import VehicleLimits
from wire.se2 import wrap_angle

__all__ = [
    "VehicleState",
    "NavlabParams",
    "TerregatorParams",
    "VehicleParams",
    "NAVLAB",
    "TERREGATOR",
    "params_for",
    "limits_of",
    "step",
    "step_navlab",
    "step_terregator",
    "integrate_arc",
    "Actuation",
    "TURN_IN_PLACE_CURVATURE",
]


@dataclass(frozen=True, slots=True)
class VehicleState:
    """Vehicle pose in the world frame and its actual motion.

    x, y [m], yaw [rad]; v [m/s] actual forward speed; kappa [1/m] actual curvature (Navlab: from the
    steering; Terregator: omega / v when moving); omega [rad/s] actual yaw rate.
    """

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    v: float = 0.0
    kappa: float = 0.0
    omega: float = 0.0


class Actuation(Protocol):
    """What `step` reads from a command: speed [m/s], curvature [1/m], optional turn rate [rad/s]."""

    @property
    def speed(self) -> float: ...

    @property
    def curvature(self) -> float: ...

    @property
    def turn_rate(self) -> float | None: ...


class NavlabParams(BaseModel):
    """Navlab van: wheelbase [m], limits [m/s], [m/s²], [1/m], [1/m/s], lags [s], footprint [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["navlab"] = "navlab"
    wheelbase: float = 3.7
    max_speed: float = 28.0 / 3.6
    max_reverse_speed: float = 2.0
    max_accel: float = 1.0
    max_decel: float = 2.5
    min_turning_radius: float = 7.0
    max_curvature_rate: float = 0.12
    speed_lag: float = 0.4
    steer_lag: float = 0.25
    length: float = 5.6
    width: float = 2.1
    rear_overhang: float = 1.0

    @property
    def max_curvature(self) -> float:
        """Return the largest curvature [1/m] (1 / minimum turning radius)."""
        return 1.0 / self.min_turning_radius


class TerregatorParams(BaseModel):
    """Terregator: skid steer with track gauge [m], limits [m/s], [m/s²], [rad/s], [rad/s²], lag [s], footprint [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["terregator"] = "terregator"
    track_width: float = 1.5
    max_speed: float = 1.0
    max_reverse_speed: float = 0.5
    max_track_speed: float = 1.2
    max_accel: float = 0.5
    max_decel: float = 1.0
    max_turn_rate: float = 0.6
    max_turn_accel: float = 1.0
    lag: float = 0.3
    length: float = 2.2
    width: float = 1.8
    rear_overhang: float = 1.1


VehicleParams = Union[NavlabParams, TerregatorParams]

#: The curvature [1/m] reported as the limit of vehicles that turn in place (effectively unlimited).
TURN_IN_PLACE_CURVATURE = 100.0
NAVLAB = NavlabParams()
TERREGATOR = TerregatorParams()


def params_for(vehicle: str) -> VehicleParams:
    """Return the default parameters of "navlab" or "terregator" (ValueError otherwise)."""
    if vehicle == "navlab":
        return NAVLAB
    if vehicle == "terregator":
        return TERREGATOR
    raise ValueError(f"unknown vehicle {vehicle!r}; expected 'navlab' or 'terregator'")


def limits_of(params: VehicleParams) -> VehicleLimits:
    """Return what a driver may command of this vehicle."""
    if isinstance(params, NavlabParams):
        return VehicleLimits(
            name="navlab", max_speed=params.max_speed, max_reverse_speed=params.max_reverse_speed,
            max_curvature=params.max_curvature, min_turning_radius=params.min_turning_radius,
            max_accel=params.max_accel, max_decel=params.max_decel, turns_in_place=False,
            max_turn_rate=params.max_speed * params.max_curvature,
        )
    return VehicleLimits(
        name="terregator", max_speed=params.max_speed, max_reverse_speed=params.max_reverse_speed,
        max_curvature=TURN_IN_PLACE_CURVATURE, min_turning_radius=0.0, max_accel=params.max_accel, max_decel=params.max_decel,
        turns_in_place=True, max_turn_rate=params.max_turn_rate,
    )


def _clip(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


def _lag(current: float, target: float, dt: float, tau: float) -> float:
    """Return the first-order-lag increment towards `target` over `dt` [s] with time constant `tau` [s]."""
    if tau <= 0.0:
        return target - current
    return (target - current) * (1.0 - math.exp(-dt / tau))


def _speed_update(v: float, v_cmd: float, dt: float, tau: float, accel: float, decel: float) -> float:
    dv = _lag(v, v_cmd, dt, tau)
    speeding_up = (v >= 0.0 and dv > 0.0) or (v <= 0.0 and dv < 0.0)
    lim = (accel if speeding_up else decel) * dt
    return v + _clip(dv, -lim, lim)


def integrate_arc(x: float, y: float, yaw: float, ds: float, dyaw: float) -> tuple[float, float, float]:
    """Move a pose (x, y [m], yaw [rad]) by arc length `ds` [m] while turning `dyaw` [rad], exactly along the arc."""
    if abs(dyaw) < 1e-9:
        c = ds * (1.0 - dyaw * dyaw / 6.0)
        return x + c * math.cos(yaw + dyaw / 2.0), y + c * math.sin(yaw + dyaw / 2.0), yaw + dyaw
    chord = 2.0 * ds / dyaw * math.sin(dyaw / 2.0)
    h = yaw + dyaw / 2.0
    return x + chord * math.cos(h), y + chord * math.sin(h), yaw + dyaw


def step_navlab(state: VehicleState, command: Actuation, dt: float, params: NavlabParams = NAVLAB) -> VehicleState:
    """Advance the Navlab by `dt` [s] towards the commanded speed [m/s] and curvature [1/m]."""
    v_cmd = _clip(command.speed, -params.max_reverse_speed, params.max_speed)
    kmax = params.max_curvature
    k_cmd = _clip(command.curvature, -kmax, kmax)
    v0, k0 = state.v, state.kappa
    v1 = _speed_update(v0, v_cmd, dt, params.speed_lag, params.max_accel, params.max_decel)
    dk = _lag(k0, k_cmd, dt, params.steer_lag)
    rate = params.max_curvature_rate * dt
    k1 = _clip(k0 + _clip(dk, -rate, rate), -kmax, kmax)
    ds = 0.5 * (v0 + v1) * dt
    dyaw = 0.5 * (k0 + k1) * ds
    x, y, yaw = integrate_arc(state.x, state.y, state.yaw, ds, dyaw)
    return VehicleState(x=x, y=y, yaw=wrap_angle(yaw), v=v1, kappa=k1, omega=v1 * k1)


def step_terregator(state: VehicleState, command: Actuation, dt: float, params: TerregatorParams = TERREGATOR) -> VehicleState:
    """Advance the Terregator by `dt` [s] towards the commanded speed [m/s] and curvature [1/m] or turn rate [rad/s]."""
    v_cmd = _clip(command.speed, -params.max_reverse_speed, params.max_speed)
    tr = command.turn_rate
    w_cmd = tr if tr is not None else v_cmd * command.curvature
    w_cmd = _clip(w_cmd, -params.max_turn_rate, params.max_turn_rate)
    # track speeds v ± ω·B/2 must stay within the drive's limit: scale both down together
    half = 0.5 * params.track_width
    peak = abs(v_cmd) + abs(w_cmd) * half
    if peak > params.max_track_speed:
        s = params.max_track_speed / peak
        v_cmd *= s
        w_cmd *= s
    v0, w0 = state.v, state.omega
    v1 = _speed_update(v0, v_cmd, dt, params.lag, params.max_accel, params.max_decel)
    dw = _lag(w0, w_cmd, dt, params.lag)
    lim = params.max_turn_accel * dt
    w1 = w0 + _clip(dw, -lim, lim)
    ds = 0.5 * (v0 + v1) * dt
    dyaw = 0.5 * (w0 + w1) * dt
    x, y, yaw = integrate_arc(state.x, state.y, state.yaw, ds, dyaw)
    kappa = w1 / v1 if abs(v1) > 1e-3 else 0.0
    return VehicleState(x=x, y=y, yaw=wrap_angle(yaw), v=v1, kappa=kappa, omega=w1)


def step(state: VehicleState, command: Actuation, dt: float, params: VehicleParams = NAVLAB) -> VehicleState:
    """Advance the vehicle described by `params` by `dt` [s] under `command`."""
    if isinstance(params, NavlabParams):
        return step_navlab(state, command, dt, params)
    return step_terregator(state, command, dt, params)

