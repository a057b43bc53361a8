"""The vehicle resting on rough ground: its height, roll and pitch from the wheel contacts, and the hazards of Figure 2.15.

Truth for the simulator only (the robot's planner has its own vehicle model and shares nothing with
this). A wheel rests on the highest ground within its contact patch (samples along the wheel's
length); the body takes the plane fitted to the wheel contacts by least squares (a suspension that
shares the load). Frames: the `vehicle` frame's origin is on that plane under the rear-axle centre
(Navlab) or the body centre (Terregator); pose (x, y, yaw) in `world`; z [m], roll, pitch [rad] by
REP-103 (roll > 0: left side up; pitch > 0: nose down), world ← vehicle = Rz(yaw)·Ry(pitch)·Rx(roll).

The environmental constraints of Navlab 1990 §2.4 (Figure 2.15), judged from the truth:

* **tip-over**: |roll| or |pitch| beyond the static stability angle, the tilt at which the centre of
  gravity passes over the downhill wheel line: atan(half track / CG height) in roll, atan(CG to the
  nearer axle / CG height) in pitch. The seeds give neither CG height nor track: the values below
  are assumed (a one-ton 1986 Chevrolet van with equipment racks on the roof for the Navlab, a low
  six-wheeled platform for the Terregator) and stated on each body.
* **high-centring**: ground under the body, between the wheels, higher than the body's clearance
  above the wheel plane (the wheels lose their grip).
* **collision with the ground**: ground under the overhangs (ahead of the front wheels, behind the
  rear ones) above the body's clearance (the bumper meets a bank), or a wheel facing a rise steeper
  than it can climb (more than its radius over its radius' length: a wall).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["Body", "BODIES", "body_for", "GroundPose", "Hazard", "rest_on_ground", "hazards"]

#: A ground height query: points (N, 2) [m] in `world` → heights (N,) [m].
HeightFn = Callable[[np.ndarray], np.ndarray]


class Body(BaseModel):
    """A vehicle's body on its wheels: wheel contact centres, wheel radius, clearance, CG, stability [m], vehicle frame."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    vehicle: str
    wheels: tuple[tuple[float, float], ...]  # contact centres (x forward, y left) [m]
    wheel_radius: float = Field(gt=0)  # [m]
    clearance: float = Field(gt=0)  # lowest point of the body above the wheel plane [m]
    cg: tuple[float, float, float]  # centre of gravity above the wheel plane (x, y, height) [m]
    footprint: tuple[float, float, float, float]  # x_min, x_max, y_min, y_max [m]
    source: str  # where these numbers come from

    @property
    def max_roll(self) -> float:
        """Return the static stability limit in roll [rad]: atan(half track / CG height)."""
        half_track = min(abs(w[1]) for w in self.wheels)
        return math.atan2(half_track, self.cg[2])

    @property
    def max_pitch(self) -> float:
        """Return the static stability limit in pitch [rad]: atan(CG to the nearer axle / CG height)."""
        xs = [w[0] for w in self.wheels]
        return math.atan2(min(self.cg[0] - min(xs), max(xs) - self.cg[0]), self.cg[2])


BODIES: dict[str, Body] = {
    # wheelbase 3.7 m (kinematics.NavlabParams), footprint as the simulator's; track, wheel, clearance and CG assumed
    "navlab": Body(vehicle="navlab", wheels=((0.0, 0.875), (0.0, -0.875), (3.7, 0.875), (3.7, -0.875)),
                   wheel_radius=0.38, clearance=0.20, cg=(1.6, 0.0, 1.2), footprint=(-1.0, 4.6, -1.05, 1.05),
                   source="wheelbase and footprint: vehicle_sim.kinematics; track 1.75 m, wheel radius 0.38 m, clearance "
                          "0.20 m and CG 1.2 m high (roof racks, generator) assumed for a 1986 one-ton van"),
    # six wheels on a 1.5 m gauge (kinematics.TerregatorParams), 0.75 m apart; wheel, clearance and CG assumed
    "terregator": Body(vehicle="terregator",
                       wheels=((-0.75, 0.75), (0.0, 0.75), (0.75, 0.75), (-0.75, -0.75), (0.0, -0.75), (0.75, -0.75)),
                       wheel_radius=0.30, clearance=0.25, cg=(0.0, 0.0, 0.7), footprint=(-1.1, 1.1, -0.9, 0.9),
                       source="gauge and footprint: vehicle_sim.kinematics; wheels 0.75 m apart, wheel radius 0.30 m, "
                              "clearance 0.25 m and CG 0.7 m high assumed for a low six-wheeled platform"),
}


def body_for(vehicle: str) -> Body:
    """Return the body of "navlab" or "terregator" (ValueError otherwise)."""
    try:
        return BODIES[vehicle]
    except KeyError:
        raise ValueError(f"unknown vehicle {vehicle!r}; expected one of {sorted(BODIES)}") from None


@dataclass(frozen=True)
class GroundPose:
    """The body at rest: height z [m] of the vehicle-frame origin, roll, pitch [rad] (REP-103); the plane's slopes.

    `slope_x`, `slope_y` [m/m] are dz along the heading and to the left of it (world z per horizontal metre).
    """

    z: float
    roll: float
    pitch: float
    slope_x: float
    slope_y: float

    def plane(self, pts_vehicle: np.ndarray) -> np.ndarray:
        """Return the wheel plane's height [m] over points (N, 2) [m] given in the level vehicle axes."""
        p = np.asarray(pts_vehicle, np.float64).reshape(-1, 2)
        return self.z + self.slope_x * p[:, 0] + self.slope_y * p[:, 1]


@dataclass(frozen=True)
class Hazard:
    """One environmental constraint broken: `kind` ("tip-over", "high-centred", "collision") and what, in words."""

    kind: str
    detail: str


def _to_world(x: float, y: float, yaw: float, pts: np.ndarray) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack([x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]])


_PATCH = np.array([-0.5, -0.25, 0.0, 0.25, 0.5])  # wheel patch samples along the wheel, in wheel radii


def _wheel_samples(body: Body) -> np.ndarray:
    """Return the wheel patch samples (n_wheels · 5, 2) [m] in the level vehicle axes, wheel by wheel."""
    w = np.asarray(body.wheels, np.float64)
    off = np.column_stack([_PATCH * body.wheel_radius, np.zeros(len(_PATCH))])
    return (w[:, None, :] + off[None, :, :]).reshape(-1, 2)


def _fit(patch_z: np.ndarray, body: Body) -> GroundPose:
    """Return the wheel plane through the highest ground under each wheel (`patch_z`: the wheel samples' heights [m])."""
    contact = patch_z.reshape(len(body.wheels), len(_PATCH)).max(axis=1)
    w = np.asarray(body.wheels, np.float64)
    A = np.column_stack([np.ones(len(w)), w])
    (z0, a, b), *_ = np.linalg.lstsq(A, contact, rcond=None)
    return GroundPose(z=float(z0), roll=float(math.asin(b / math.sqrt(1.0 + a * a + b * b))), pitch=float(-math.atan(a)),
                      slope_x=float(a), slope_y=float(b))


def rest_on_ground(height: HeightFn, x: float, y: float, yaw: float, body: Body) -> GroundPose:
    """Return how the body rests at (x, y) [m], heading yaw [rad], on the ground that `height` describes."""
    pts = _wheel_samples(body)
    return _fit(np.asarray(height(_to_world(x, y, yaw, pts)), np.float64), body)


def _grid(x0: float, x1: float, y0: float, y1: float, step: float = 0.15) -> np.ndarray:
    xs = np.linspace(x0, x1, max(2, int(math.ceil((x1 - x0) / step)) + 1))
    ys = np.linspace(y0, y1, max(2, int(math.ceil((y1 - y0) / step)) + 1))
    return np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)


@lru_cache(maxsize=8)
def _body_samples(body: Body) -> tuple[np.ndarray, int, int]:
    """Return the body's ground samples (K, 2) [m], level vehicle axes: wheel patches, then under the body between the
    wheels, then under the overhangs; and where the second and third groups start."""
    xs = [w[0] for w in body.wheels]
    ys = [w[1] for w in body.wheels]
    inner = body.wheel_radius * 0.6  # keep the samples off the wheels themselves
    fx0, fx1, fy0, fy1 = body.footprint
    under = _grid(min(xs) + inner, max(xs) - inner, min(ys) + inner, max(ys) - inner)
    front, rear = max(xs) + body.wheel_radius, min(xs) - body.wheel_radius
    over = [_grid(front, fx1, fy0, fy1)] if fx1 > front else []
    over += [_grid(fx0, rear, fy0, fy1)] if fx0 < rear else []
    wheels = _wheel_samples(body)
    pts = np.vstack([wheels, under] + over)
    pts.setflags(write=False)
    return pts, len(wheels), len(wheels) + len(under)


def hazards(height: HeightFn, x: float, y: float, yaw: float, body: Body) -> tuple[GroundPose, list[Hazard]]:
    """Return how the body rests at (x, y) [m], yaw [rad], and the constraints it breaks there (empty when safe)."""
    pts, a, b = _body_samples(body)
    z = np.asarray(height(_to_world(x, y, yaw, pts)), np.float64)
    pose = _fit(z[:a], body)
    out: list[Hazard] = []
    if abs(pose.roll) > body.max_roll or abs(pose.pitch) > body.max_pitch:
        out.append(Hazard("tip-over", f"roll {math.degrees(pose.roll):.1f}°, pitch {math.degrees(pose.pitch):.1f}° beyond "
                                      f"{math.degrees(body.max_roll):.0f}° / {math.degrees(body.max_pitch):.0f}°"))
    lift = z[a:b] - pose.plane(pts[a:b])
    if b > a and float(lift.max()) > body.clearance:
        out.append(Hazard("high-centred", f"ground {float(lift.max()):.2f} m above the wheel plane under the body "
                                          f"(clearance {body.clearance:.2f} m)"))
    rise = z[b:] - pose.plane(pts[b:])
    patches = z[:a].reshape(len(body.wheels), len(_PATCH))
    step = float((patches.max(axis=1) - patches.min(axis=1)).max())
    if len(rise) and float(rise.max()) > body.clearance:
        out.append(Hazard("collision", f"the body's overhang meets the ground ({float(rise.max()):.2f} m above the wheel plane)"))
    elif step > body.wheel_radius:
        out.append(Hazard("collision", f"a wheel faces a rise of {step:.2f} m within its radius (a wall it cannot climb)"))
    return pose, out
