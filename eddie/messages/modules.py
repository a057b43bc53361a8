"""Messages of EDDIE's perception/behaviour modules and the mission service (seed: Navlab 1990 §2.5, ch. 3).

`ModuleSwitch` is what a trigger tells a module (wake, sleep, change mode); the mission service
answers `route` with the mission's `MissionRoute` (the route the compiled triggers lie along).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from eddie.toolkit.message import Message, message_type

__all__ = ["ModuleSwitch", "RouteQuery", "MissionRoute", "ObstacleSeen", "ObjectStopped"]


@message_type("modules.switch")
class ModuleSwitch(Message):
    """Wake (`on`) or put to sleep a module, optionally in a `mode` (e.g. vision "through_intersection"); `reason` for the log.

    `mission_id`: set by the mission service when a mission starts (`on`) or ends (asleep); a module
    that keeps the running mission's route asks for the route of this mission again.
    """

    on: bool
    mode: str = ""
    reason: str = ""
    mission_id: str = ""


@message_type("modules.route_query")
class RouteQuery(Message):
    """Ask the mission service for the running mission's route."""


@message_type("modules.route")
class MissionRoute(Message):
    """The running mission's route: `points` (x, y) [m] in `world` (the roads' centre line), the speed [m/s] from each point
    on, and the offset [m] left (+) of the route of the lane driven at each point, where a step keeps to a side (empty:
    none given; road following then keeps its own `keep` side on the road where the vehicle is); empty: no mission."""

    mission_id: str = ""
    points: tuple[tuple[float, float], ...] = ()
    speeds: tuple[float, ...] = ()
    offsets: tuple[float, ...] = ()
    state: Literal["none", "running", "finished"] = "none"

    @model_validator(mode="after")
    def _one_offset_per_point(self) -> "MissionRoute":
        if self.offsets and len(self.offsets) != len(self.points):
            raise ValueError(f"offsets: {len(self.offsets)} for {len(self.points)} points (one per point, or none)")
        return self


@message_type("modules.object_stopped")
class ObjectStopped(Message):
    """Obstacle stop held the vehicle at `object_id` at `stamp` [s] sim, `distance_m` [m] from its goal point as believed
    after `sightings` laser sightings of the object moved the belief by `correction` (dx, dy) [m] `world`."""

    stamp: float
    object_id: str
    distance_m: float
    sightings: int = Field(0, ge=0)
    correction: tuple[float, float] = (0.0, 0.0)


@message_type("modules.obstacle_seen")
class ObstacleSeen(Message):
    """Obstacle stop's verdict on one range image at `stamp` [s] sim: blocked, nearest return ahead [m]."""

    stamp: float
    blocked: bool
    distance_m: float | None = None
    points: int = Field(0, ge=0)
