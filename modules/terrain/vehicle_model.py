"""What the cross-country planner knows of a vehicle: wheels, body, clearances, tip-over limits, turning (Navlab 1990 §2.4).

Frame `vehicle`: u forward, v left [m], origin at the configuration's reference point — the centre
of the wheelbase, the "center of the vehicle" the paper places in configuration space. The wheels
must be laid out symmetrically about it (Σu = Σv = Σuv = 0), so the least-squares plane through the
wheel contacts has pitch and roll that each depend on one sum (see `constraints`).

Sources: the Navlab's 7 m minimum turning radius is the seed's (§2.4); the Terregator's six wheels and
skid steer are the design's (DESIGN.md, the seeds do not give them); every other figure is *assumed* (a one-ton Chevrolet van
for the Navlab; the Terregator's size as our simulator gives it), chosen conservative, and stated
beside its field.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from modules.terrain.errors import TerrainError

__all__ = ["TerrainVehicle", "NAVLAB_TERRAIN", "TERREGATOR_TERRAIN", "terrain_vehicle_for"]


class TerrainVehicle(BaseModel):
    """A vehicle's geometry and limits on rough ground: wheel contacts, body box, clearances [m], tip-over limits [rad]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    wheels: tuple[tuple[float, float], ...] = Field(description="wheel contact points (u, v) [m] in `vehicle`")
    wheel_patch: float = Field(gt=0.0, description="radius of a wheel's contact patch [m]: the wheel rests on the highest cell in it")
    body_rear: float = Field(gt=0.0, description="the body reaches this far behind the reference point [m]")
    body_front: float = Field(gt=0.0, description="the body reaches this far ahead of the reference point [m]")
    body_half_width: float = Field(gt=0.0, description="[m]")
    clearance: float = Field(gt=0.0, description="belly between the axles above the wheels' plane [m] (high-centring)")
    overhang_clearance: float = Field(gt=0.0, description="body ahead of and behind the axles above the wheels' plane [m] (collision)")
    max_roll: float = Field(gt=0.0, lt=math.pi / 2, description="tip-over limit across the body [rad]")
    max_pitch: float = Field(gt=0.0, lt=math.pi / 2, description="tip-over / climbing limit along the body [rad]")
    max_step: float = Field(gt=0.0, description="the largest discontinuity a wheel can stand on or climb [m] (collision)")
    steering: Literal["ackermann", "skid"] = Field(description="ackermann: forward arcs no tighter than the turning radius; skid: also turns in place")
    min_turning_radius: float = Field(ge=0.0, description="[m] (0 for a vehicle that turns in place)")
    reference_ahead: float = Field(0.0, description="the reference point lies this far ahead of the origin of the vehicle's "
                                   "pose frame [m] (the Navlab's frame is its rear axle, its reference point mid-wheelbase)")

    @model_validator(mode="after")
    def _symmetric(self) -> "TerrainVehicle":
        n = len(self.wheels)
        su, sv = sum(u for u, _ in self.wheels), sum(v for _, v in self.wheels)
        suv = sum(u * v for u, v in self.wheels)
        suu, svv = sum(u * u for u, _ in self.wheels), sum(v * v for _, v in self.wheels)
        if n < 4 or max(abs(su), abs(sv), abs(suv)) > 1e-6 or suu <= 0.0 or svv <= 0.0:
            raise ValueError(f"{self.name}: the wheels {self.wheels} must be ≥ 4 contacts laid out symmetrically about "
                             f"the reference point (Σu = Σv = Σuv = 0, spread along and across)")
        if self.steering == "ackermann" and self.min_turning_radius <= 0.0:
            raise ValueError(f"{self.name}: an ackermann vehicle needs a minimum turning radius > 0 m")
        for u, v in self.wheels:
            if not (-self.body_rear <= u <= self.body_front and abs(v) <= self.body_half_width):
                raise ValueError(f"{self.name}: wheel ({u}, {v}) lies outside the body")
        return self

    def reference_of(self, x: float, y: float, yaw: float) -> tuple[float, float, float]:
        """Return the configuration (x, y [m], θ [rad]) of a vehicle whose pose frame is at (x, y, yaw) (same frame)."""
        return (x + self.reference_ahead * math.cos(yaw), y + self.reference_ahead * math.sin(yaw), yaw)

    def origin_of(self, configs: np.ndarray) -> np.ndarray:
        """Return the poses (n, 3) of the vehicle's pose frame at configurations `configs` (n, 3) x, y [m], θ [rad]: `reference_of` undone."""
        out = np.array(configs, dtype=np.float64, copy=True).reshape(-1, 3)
        out[:, 0] -= self.reference_ahead * np.cos(out[:, 2])
        out[:, 1] -= self.reference_ahead * np.sin(out[:, 2])
        return out

    @property
    def axle_span(self) -> tuple[float, float]:
        """Return (u of the rearmost wheels, u of the foremost wheels) [m]: the belly lies between them."""
        us = [u for u, _ in self.wheels]
        return min(us), max(us)

    @property
    def max_curvature(self) -> float:
        """Return the largest path curvature [1/m] (inf for a vehicle that turns in place)."""
        return math.inf if self.min_turning_radius == 0.0 else 1.0 / self.min_turning_radius


def _four_wheels(wheelbase: float, track: float) -> tuple[tuple[float, float], ...]:
    a, b = wheelbase / 2.0, track / 2.0
    return ((a, b), (a, -b), (-a, b), (-a, -b))


#: The Navlab (a Chevrolet one-ton van): wheelbase 3.7 m, track 1.75 m, 5.6 m × 2.1 m body with 1.0 m
#: behind the rear axle (assumed); 0.20 m under the belly and the bumpers (a van's bumper hangs about as low as its
#: floor pan; assumed), less 2 cm for the terrain map's own error (a first guess of 0.35 m under the bumpers let
#: the planner put a bumper over a rock);
#: 20° roll and 25° pitch, well inside a van's static tip-over angle of about 38° (assumed); a wheel
#: climbs 0.2 m, about half its 0.38 m radius (assumed); 7 m minimum turning radius (seed §2.4); its pose frame is
#: its rear axle, half the wheelbase behind the reference point (as the PILOT's road planner has it).
NAVLAB_TERRAIN = TerrainVehicle(
    name="navlab", wheels=_four_wheels(3.7, 1.75), wheel_patch=0.15, body_rear=2.85, body_front=2.75,
    body_half_width=1.05, clearance=0.18, overhang_clearance=0.18, max_roll=math.radians(20.0),
    max_pitch=math.radians(25.0), max_step=0.20, steering="ackermann", min_turning_radius=7.0, reference_ahead=1.85)

#: The Terregator: six wheels, skid steer turning in place (DESIGN.md); three axles 0.8 m apart, 1.5 m
#: track, a 2.2 m × 1.8 m body, 0.25 m under the belly and the ends, 20° roll and pitch,
#: 0.2 m steps (assumed).
TERREGATOR_TERRAIN = TerrainVehicle(
    name="terregator", wheels=tuple((u, v) for u in (-0.8, 0.0, 0.8) for v in (0.75, -0.75)), wheel_patch=0.15,
    body_rear=1.1, body_front=1.1, body_half_width=0.9, clearance=0.25, overhang_clearance=0.25,
    max_roll=math.radians(20.0), max_pitch=math.radians(20.0), max_step=0.20, steering="skid", min_turning_radius=0.0)


def terrain_vehicle_for(name: str) -> TerrainVehicle:
    """Return the default model of "navlab" or "terregator"."""
    presets = {"navlab": NAVLAB_TERRAIN, "terregator": TERREGATOR_TERRAIN}
    if name not in presets:
        raise TerrainError(f"unknown vehicle {name!r}; expected one of {sorted(presets)}")
    return presets[name]
