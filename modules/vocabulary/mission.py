"""Mission vocabulary: missions, mission steps, step results and mission status (CAPTAIN ↔ MAP NAVIGATOR).

Seed §2.3.1: a mission is a sequence of steps; each step has a destination (where to go), constraints
(how to go) and a trigger with an action. The CAPTAIN sends one step at a time to the MAP NAVIGATOR
and gets back success or failure. Coordinates are in the `world` frame [m].
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from modules.vocabulary._base import XY, Frozen, NonNeg, Pose, finite, token_type

__all__ = [
    "KeepSide", "TriggerAction", "MissionState", "Destination", "StepConstraints", "Trigger", "MissionStart",
    "DEFAULT_TOLERANCE_M",
    "MissionStepSpec", "Mission", "MissionStep", "StepResult", "StepOutcome", "MissionStatus",
    "TERMINAL_STATES", "StepProgress", "Waiting",
]

#: Which side of the path to keep to; None = centre of the path.
KeepSide = Literal["right", "left"]
#: What the CAPTAIN does when a step's trigger fires (the step arrived).
TriggerAction = Literal["stop", "wait", "continue"]
#: Lifecycle of a mission.
MissionState = Literal["queued", "running", "succeeded", "failed", "cancelled"]
#: States a mission never leaves.
TERMINAL_STATES: frozenset[str] = frozenset({"succeeded", "failed", "cancelled"})


class Destination(Frozen):
    """Where a step goes: a named place of the map, or a point (x [m], y [m]) in the world frame.

    `off_road`: the point itself, reached across country (Navlab 1990 §2.4), not projected onto a path.
    """

    place: str | None = None
    xy: XY | None = None
    off_road: bool = False

    @model_validator(mode="after")
    def _exactly_one(self) -> "Destination":
        if (self.place is None) == (self.xy is None):
            raise ValueError("give exactly one of place (a named place) or xy (world coordinates)")
        if self.place is not None and not self.place.strip():
            raise ValueError("place must be a non-empty name")
        if self.off_road and self.xy is None:
            raise ValueError("off_road needs a point (x, y), not a place")
        return self

    def describe(self) -> str:
        """Return a short human-readable form ("place NAME" or "(x, y)")."""
        if self.place is not None:
            return f"place {self.place!r}"
        assert self.xy is not None
        return f"({self.xy[0]:.1f}, {self.xy[1]:.1f}){' off road' if self.off_road else ''}"


class StepConstraints(Frozen):
    """How to go: keep to a side, avoid stairs/slopes, a speed limit [m/s]."""

    keep: KeepSide | None = None
    avoid_stairs: bool = False
    avoid_slope: bool = False
    speed_limit: Annotated[float, Field(gt=0.0, le=20.0)] | None = None


class Trigger(Frozen):
    """Action taken when the step's trigger condition (arrival at the destination) is satisfied.

    stop: end the mission there (succeeded); wait: hold for wait_s [s] sim time, then go on;
    continue: go straight on to the next step.
    """

    action: TriggerAction = "continue"
    wait_s: NonNeg = 0.0

    @model_validator(mode="after")
    def _wait_needs_time(self) -> "Trigger":
        if self.action == "wait" and self.wait_s <= 0.0:
            raise ValueError("action 'wait' needs wait_s > 0 [s]")
        if self.action != "wait" and self.wait_s != 0.0:
            raise ValueError(f"wait_s is only meaningful with action 'wait', not {self.action!r}")
        return self


#: How close [m] the vehicle must truly come to a step's destination when the mission does not say.
DEFAULT_TOLERANCE_M = 1.5


class MissionStepSpec(Frozen):
    """One step of a mission as written by the person: name, destination, constraints, trigger.

    `tolerance` [m] is how close to the destination the vehicle must truly be when the step ends
    for evaluation to count it reached.
    """

    name: str
    destination: Destination
    constraints: StepConstraints = StepConstraints()
    trigger: Trigger = Trigger()
    tolerance: Annotated[finite, Field(gt=0.0)] = DEFAULT_TOLERANCE_M


class MissionStart(Frozen):
    """Where the vehicle stands when the mission begins: x, y [m] in `world`, heading [deg] CCW from +x."""

    x: finite
    y: finite
    yaw_deg: finite


@token_type("mission")
class Mission(Frozen):
    """A whole mission, as accepted by the CAPTAIN (seen only by the CAPTAIN and monitors)."""

    mission_id: str
    name: str
    description: str = ""
    world: str | None = None
    vehicle: Literal["terregator", "navlab"] | None = None
    start: MissionStart | None = None
    steps: Annotated[tuple[MissionStepSpec, ...], Field(min_length=1)]


@token_type("mission_step")
class MissionStep(Frozen):
    """One step sent by the CAPTAIN to the MAP NAVIGATOR: destination and constraints only.

    The CAPTAIN updates `state` to "cancelled" to withdraw the step.
    """

    mission_id: str
    step_index: Annotated[int, Field(ge=0)]
    name: str
    destination: Destination
    constraints: StepConstraints = StepConstraints()
    state: Literal["active", "cancelled"] = "active"


@token_type("step_result")
class StepResult(Frozen):
    """The MAP NAVIGATOR's verdict on a mission step: success or failure with the reason."""

    mission_id: str
    step_index: Annotated[int, Field(ge=0)]
    success: bool
    reason: str = ""
    route_length_m: NonNeg = 0.0
    segments_done: Annotated[int, Field(ge=0)] = 0
    replans: Annotated[int, Field(ge=0)] = 0


class StepOutcome(Frozen):
    """Progress of one step inside a mission status; times in sim time [s]."""

    step_index: Annotated[int, Field(ge=0)]
    name: str
    state: Literal["pending", "running", "waiting", "succeeded", "failed", "cancelled"] = "pending"
    reason: str = ""
    started_at: float | None = None
    finished_at: float | None = None


#: Why the vehicle of a running step is not driving on what it perceives: something stands on its path
#: ("obstacle hold"), nothing to drive yet ("planning"), or it drives on its odometry alone ("dead reckoning").
Waiting = Literal["", "obstacle hold", "planning", "dead reckoning"]


class StepProgress(Frozen):
    """Where a running mission is, as the robot believes it (never truth), when its mission service answered.

    `sim_time_s` [s sim] of the answer; `route_done_m` / `route_left_m` [m] along the current step's route
    (its newest plan, `world`) before and after the believed position's projection onto it (None: no route or
    no estimate yet); `pose` the believed pose in `world` (None: none yet); `since_progress_s` [s sim] since the
    believed position last got `progress_m` farther along the route (or since the step started); `waiting` why the
    vehicle is not driving on what it perceives ("": it is).
    """

    sim_time_s: finite
    step_index: Annotated[int, Field(ge=0)]
    route_done_m: NonNeg | None = None
    route_left_m: NonNeg | None = None
    pose: Pose | None = None
    since_progress_s: NonNeg | None = None
    progress_m: NonNeg = 0.5
    waiting: Waiting = ""


@token_type("mission_status")
class MissionStatus(Frozen):
    """The CAPTAIN's view of a mission: state, current step, per-step outcomes, reason; times [s] sim.

    `progress` (a running mission's, in answers to status queries only; None in the posted token and the
    events stream) is where the mission is as the robot believes it.
    """

    mission_id: str
    name: str
    state: MissionState
    current_step: Annotated[int, Field(ge=0)] | None = None
    step_count: Annotated[int, Field(ge=1)]
    steps: tuple[StepOutcome, ...] = ()
    reason: str = ""
    submitted_at: float | None = None
    finished_at: float | None = None
    progress: StepProgress | None = None

    @property
    def terminal(self) -> bool:
        """Return whether the mission has finished (succeeded, failed or cancelled)."""
        return self.state in TERMINAL_STATES
