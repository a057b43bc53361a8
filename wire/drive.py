"""The drive interface: the messages between a driver (the HELM) and the simulated vehicle, and their wire codec.

Frames: `world` (truth, x east / y north [m]), `local` (odometry: starts at (0, 0, 0) at the start pose
and drifts; never jumps), `vehicle` (x forward, y left, at the rear axle / body centre).
Wire format: msgpack of the model's fields (JSON accepted on input: a payload starting with `{`).
"""

from __future__ import annotations

import json
import math
from typing import Literal, TypeVar

import msgpack
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from wire.errors import PayloadError
from wire.health import Heartbeat
from wire.se2 import PoseFields

__all__ = [
    "DriveCommand",
    "DriveStep",
    "MAX_DRIVE_STEPS",
    "Odometry",
    "TruthPose",
    "SimEvent",
    "SimClock",
    "OdometrySlip",
    "VehicleLimits",
    "SimInfo",
    "SimHeartbeat",
    "EVENT_KINDS",
    "MAX_COMMAND_DURATION",
    "DriveMessageError",
    "WireError",
    "encode",
    "decode",
]

#: Longest duration a single command may hold [s] (sim time).
MAX_COMMAND_DURATION = 30.0

#: Most timed steps one command may carry behind it (`DriveCommand.then`).
MAX_DRIVE_STEPS = 64

#: Kinds of simulator events.
EVENT_KINDS = ("collision", "off-path", "on-path", "watchdog", "commands-exhausted", "rejected")

_FROZEN = ConfigDict(frozen=True, extra="forbid")


class DriveMessageError(PayloadError, ValueError):
    """A payload that is not a valid drive-interface message; says what is wrong."""


#: The name callers have used for it.
WireError = DriveMessageError


class DriveStep(BaseModel):
    """One timed step behind a command: `speed` [m/s], `curvature` [1/m], optional `turn_rate` [rad/s], `duration` [s] sim."""

    model_config = _FROZEN

    speed: float = Field(allow_inf_nan=False)
    curvature: float = Field(default=0.0, allow_inf_nan=False)
    turn_rate: float | None = Field(default=None, allow_inf_nan=False)
    duration: float = Field(gt=0.0, le=MAX_COMMAND_DURATION, allow_inf_nan=False)


class DriveCommand(BaseModel):
    """Drive the vehicle at `speed` [m/s] (negative = reverse) along `curvature` [1/m] (positive = left).

    `mode="immediate"` replaces whatever is executing and clears the queue; `mode="queued"` runs after
    the commands already queued and needs a `duration` [s]. A command without a duration holds until
    the next command arrives and is guarded by the watchdog; a timed command holds for its duration
    (sim time) and then the next queued one starts (the vehicle stops when the queue runs out).
    `then` (a timed command only) are steps that run behind it as if queued one by one: a driver's
    prediction of its next commands along its plan, so a driver held up leaves the vehicle following
    the plan for that long rather than holding one arc (at most `MAX_DRIVE_STEPS`).
    `turn_rate` [rad/s] overrides the curvature for skid-steer vehicles (the Terregator turns in
    place with `speed=0`); Ackermann vehicles reject it. `seq` is the sender's sequence number.
    `sensed_at` [s sim] is the capture stamp of the newest sensor data the command derives from (None:
    none, e.g. dead reckoning): sense-to-act latency is the command's arrival minus it.
    """

    model_config = _FROZEN

    speed: float = Field(allow_inf_nan=False)
    curvature: float = Field(default=0.0, allow_inf_nan=False)
    mode: Literal["immediate", "queued"] = "immediate"
    duration: float | None = Field(default=None, gt=0.0, le=MAX_COMMAND_DURATION, allow_inf_nan=False)
    turn_rate: float | None = Field(default=None, allow_inf_nan=False)
    seq: int = 0
    sensed_at: float | None = Field(default=None, ge=0.0, allow_inf_nan=False)
    then: tuple[DriveStep, ...] = Field(default=(), max_length=MAX_DRIVE_STEPS)

    @model_validator(mode="after")
    def _queued_needs_duration(self) -> "DriveCommand":
        if self.mode == "queued" and self.duration is None:
            raise ValueError("a queued command needs a duration [s]")
        if self.then and self.duration is None:
            raise ValueError("steps behind a command (then) need the command to be timed: give it a duration [s]")
        return self


class Odometry(PoseFields, BaseModel):
    """Dead-reckoned pose of `vehicle` in the `local` frame at sim time `stamp` [s]: x, y [m], yaw [rad].

    `v` [m/s] and `omega` [rad/s] are the measured speed and yaw rate; `distance` [m] the odometer.
    """

    model_config = _FROZEN

    stamp: float
    x: float
    y: float
    yaw: float
    v: float
    omega: float
    distance: float
    frame: Literal["local"] = "local"
    child_frame: Literal["vehicle"] = "vehicle"


class TruthPose(PoseFields, BaseModel):
    """True pose of `vehicle` in the `world` frame at sim time `stamp` [s] (evaluation and monitor only).

    x, y, z [m] (z = ground height), yaw [rad], v [m/s], omega [rad/s], curvature [1/m] actually driven;
    roll, pitch [rad] of the body resting on rough ground (REP-103: roll > 0 left side up, pitch > 0 nose
    down; 0 on flat worlds).
    """

    model_config = _FROZEN

    stamp: float
    x: float
    y: float
    z: float
    yaw: float
    v: float
    omega: float
    curvature: float
    roll: float = 0.0
    pitch: float = 0.0
    frame: Literal["world"] = "world"


class SimEvent(BaseModel):
    """Something that happened to the vehicle at sim time `stamp` [s], at world (x, y) [m].

    kinds: collision (with `object_id`), off-path / on-path (leaving / re-entering path objects),
    watchdog (commands stopped arriving: vehicle stopped), commands-exhausted (timed commands ran out),
    rejected (a command the vehicle cannot execute; `detail` says why); on rough ground (a world with
    terrain) tip-over (roll or pitch beyond the vehicle's static stability) and high-centred (ground
    under the body, between the wheels, above its clearance); a collision with the ground itself (a
    step a wheel cannot climb, a bank the body's overhang meets) has `object_kind` "terrain".
    """

    model_config = _FROZEN

    stamp: float
    kind: Literal["collision", "off-path", "on-path", "watchdog", "commands-exhausted", "rejected", "tip-over", "high-centred"]
    x: float
    y: float
    object_id: str | None = None
    object_kind: str | None = None
    detail: str = ""


class OdometrySlip(BaseModel):
    """A fault for the simulator: jump the odometry by (dx, dy [m], dyaw [rad]) in the `vehicle` frame.

    The one exception to `local` never jumping: a wheel slip or encoder glitch, injected by the
    launcher's `position-jump` fault (issue 10) — evaluation only, never a module.
    """

    model_config = _FROZEN

    dx: float = Field(default=0.0, allow_inf_nan=False, ge=-50.0, le=50.0)
    dy: float = Field(default=0.0, allow_inf_nan=False, ge=-50.0, le=50.0)
    dyaw: float = Field(default=0.0, allow_inf_nan=False, ge=-3.15, le=3.15)


class SimClock(BaseModel):
    """Simulated time `stamp` [s] and the real-time factor asked for (`rtf`) and reached (`rtf_actual`)."""

    model_config = _FROZEN

    stamp: float
    rtf: float
    rtf_actual: float
    step: int


class VehicleLimits(BaseModel):
    """What a driver may ask of the vehicle: speeds [m/s], curvature [1/m], turn-in-place."""

    model_config = _FROZEN

    name: str
    max_speed: float
    max_reverse_speed: float
    max_curvature: float
    min_turning_radius: float
    max_accel: float
    max_decel: float
    turns_in_place: bool
    max_turn_rate: float


class SimInfo(BaseModel):
    """The running simulator: world, vehicle and its limits, rates [Hz], the start pose in the world frame."""

    model_config = _FROZEN

    world: str
    vehicle: Literal["terregator", "navlab"]
    limits: VehicleLimits
    seed: int
    rtf: float
    physics_hz: float
    publish_hz: float
    watchdog_timeout: float
    start_x: float
    start_y: float
    start_yaw: float
    map_error: float


class SimHeartbeat(Heartbeat):
    """The node's sign of life, the heartbeat every process publishes (`wire.health.Heartbeat`), named "sim"."""

    module: str = "sim"


M = TypeVar("M", bound=BaseModel)


def encode(msg: BaseModel, *, as_json: bool = False) -> bytes:
    """Encode a drive-interface message as msgpack (default) or JSON."""
    if as_json:
        return json.dumps(msg.model_dump(mode="json"), separators=(",", ":")).encode()
    return msgpack.packb(msg.model_dump(), use_bin_type=True)


def decode(cls: type[M], payload: bytes | bytearray | memoryview) -> M:
    """Decode a msgpack or JSON payload into `cls`; raise `WireError` saying what is wrong."""
    raw = bytes(payload)
    if not raw:
        raise WireError(f"empty payload for {cls.__name__}")
    try:
        if raw[:1] in (b"{", b" ", b"\n"):
            data = json.loads(raw.decode("utf-8"), parse_constant=lambda c: math.nan)
        else:
            data = msgpack.unpackb(raw, raw=False, strict_map_key=True)
    except Exception as exc:  # noqa: BLE001 - msgpack/json raise assorted errors on garbage
        raise WireError(f"{cls.__name__}: payload is neither msgpack nor JSON: {type(exc).__name__}: {exc}"[:300]) from None
    if not isinstance(data, dict):
        raise WireError(f"{cls.__name__}: payload must be a map of fields, got {type(data).__name__}")
    try:
        return cls.model_validate(data)
    except ValidationError as exc:
        parts = [f"{'.'.join(str(x) for x in e['loc']) or '<root>'}: {e['msg']}" for e in exc.errors()]
        raise WireError(f"{cls.__name__}: " + "; ".join(parts)) from None
