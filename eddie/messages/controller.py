"""Messages of the integrated controller (seed: Navlab 1990 §2.5): commands, position, state, path, events.

Every position is in the `local` frame (the controller's dead-reckoned frame: never corrected, never
jumps). Commands go to the controller's inbox (fire and forget) or its `command` service (answered
with a `CommandAck`); `Position` answers the `position` service; `ControllerState`, `ControllerPath`
and `ControllerEvent` are its streams `state`, `path`, `events`.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from eddie.toolkit.message import Finite, Message, message_type
from wire.se2 import PoseFields

__all__ = [
    "XY", "MAX_TRAIL", "CommandMode", "ControllerMode", "PathCommand", "DeadReckon", "SpeedLimit", "Nudge", "Stop", "Release",
    "CommandAck", "PositionQuery", "Position", "RecordedPathQuery", "RecordedPath", "ControllerState",
    "ControllerPath", "ControllerEvent", "ControllerCommand",
]


_F = Finite
#: A point (x [m], y [m]) in `local`.
XY = tuple[_F, _F]
#: Odometry samples a state's `trail` carries at most (10 s sim at the controller's 10 Hz).
MAX_TRAIL = 100
#: `immediate` replaces the current path; `queued` is appended to it.
CommandMode = Literal["immediate", "queued"]
#: What the controller is doing.
ControllerMode = Literal["idle", "tracking", "dead_reckon", "stopped"]


class _Command(Message):
    client: str = Field(min_length=1, description="the commanding client's name")
    priority: int = Field(0, description="higher wins; a lower one is refused while a higher one holds control")


@message_type("controller.path_command")
class PathCommand(_Command):
    """Track `points` (local [m]) at `speed` [m/s] (or per-point `speeds`); `sensed_at` [s sim]: the newest sensor data used."""

    mode: CommandMode = "immediate"
    points: tuple[XY, ...] = Field(min_length=2)
    speed: _F = Field(1.0, ge=0.0)
    speeds: tuple[_F, ...] | None = None
    sensed_at: float | None = Field(None, ge=0.0)

    @model_validator(mode="after")
    def _speeds_match(self) -> "PathCommand":
        if self.speeds is not None and len(self.speeds) != len(self.points):
            raise ValueError(f"speeds: {len(self.speeds)} speeds for {len(self.points)} points")
        return self


@message_type("controller.dead_reckon")
class DeadReckon(_Command):
    """Follow a recorded path by dead reckoning: `points` (local [m]) given, or the controller's own record between two odometer readings [m]."""

    mode: CommandMode = "immediate"
    points: tuple[XY, ...] | None = None
    odometer_from: float | None = None
    odometer_to: float | None = None
    speed: _F = Field(0.5, ge=0.0)

    @model_validator(mode="after")
    def _one_source(self) -> "DeadReckon":
        has_points = self.points is not None
        has_record = self.odometer_from is not None and self.odometer_to is not None
        if has_points == has_record:
            raise ValueError("points: give either points or both odometer_from and odometer_to")
        if has_points and len(self.points) < 2:  # type: ignore[arg-type]
            raise ValueError("points: a recorded path needs at least 2 points")
        return self


@message_type("controller.speed_limit")
class SpeedLimit(_Command):
    """Cap the speed at `speed` [m/s] from now on (None: no cap) — the seed's "set speed" trigger."""

    speed: float | None = Field(None, ge=0.0)


@message_type("controller.nudge")
class Nudge(Message):
    """Add `dv` [m/s] and `dk` [1/m] to what is commanded; each source's offset decays (joystick, soft bumper)."""

    source: str = Field(min_length=1)
    dv: _F = 0.0
    dk: _F = 0.0


@message_type("controller.stop")
class Stop(_Command):
    """Stop at once and drop every path (any client may stop the vehicle), saying why."""

    reason: str = ""


@message_type("controller.release")
class Release(Message):
    """Give up control held by `client` (the path being driven goes on)."""

    client: str = Field(min_length=1)


#: Every command the controller accepts.
ControllerCommand = PathCommand | DeadReckon | SpeedLimit | Nudge | Stop | Release


@message_type("controller.ack")
class CommandAck(Message):
    """The controller's answer to a command: accepted or not, why, and who holds control."""

    accepted: bool
    reason: str = ""
    holder: str | None = None


@message_type("controller.position_query")
class PositionQuery(Message):
    """Ask for the controller's current dead-reckoned position."""


@message_type("controller.position")
class Position(PoseFields, Message):
    """The vehicle's dead-reckoned pose in `local` at sim time `stamp` [s]: x, y [m], yaw [rad], speed `v` [m/s]."""

    stamp: float
    x: float
    y: float
    yaw: float
    v: float


@message_type("controller.recorded_path_query")
class RecordedPathQuery(Message):
    """Ask for the path driven between odometer readings `odometer_from` and `odometer_to` [m]."""

    odometer_from: float
    odometer_to: float


@message_type("controller.recorded_path")
class RecordedPath(Message):
    """A stretch of the path the controller drove, in `local` [m], with the odometer [m] it spans."""

    points: tuple[XY, ...]
    odometer_from: float
    odometer_to: float


@message_type("controller.state")
class ControllerState(PoseFields, Message):
    """What the controller does at sim time `stamp` [s]: pose in `local`, speed [m/s], curvature [1/m], client, mode."""

    stamp: float
    x: float
    y: float
    yaw: float
    v: float
    curvature: float
    client: str = ""
    mode: ControllerMode = "idle"
    odometer: float = 0.0
    speed_limit: float | None = None
    mission_speed: float | None = None
    #: the odometry (stamp [s], x [m], y [m], yaw [rad] in `local`) of the control periods since the previous
    #: state, oldest first, this one's not among them: a controller held up (a loaded machine at a high RTF)
    #: hands on what queued meanwhile, so a module keeping the pose history has no holes in it
    trail: tuple[tuple[_F, _F, _F, _F], ...] = Field(default=(), max_length=MAX_TRAIL)


@message_type("controller.path")
class ControllerPath(Message):
    """The path the controller tracks (empty: none), as [x, y] pairs in `local` [m].

    `offered` is the newest path a client offered while another held control (refused for its priority;
    empty: none since the last accepted path), from `offered_client`: what the vehicle would drive if the
    holder let go. Obstacle stop, holding, looks along it too.
    """

    stamp: float
    path: tuple[XY, ...]
    frame: Literal["local"] = "local"
    client: str = ""
    mode: ControllerMode = "idle"
    offered: tuple[XY, ...] = ()
    offered_client: str = ""


@message_type("controller.event")
class ControllerEvent(Message):
    """Something the controller did at sim time `stamp` [s]: accepted, refused, stop, release, path done, …"""

    stamp: float
    kind: str
    client: str = ""
    detail: str = ""
