"""Module health vocabulary: the heartbeat every module publishes."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from blackboard.registry import token_type
from modules.vocabulary._base import Frozen, NonNeg

__all__ = ["ModuleState", "Heartbeat"]

#: Lifecycle state a module reports in its heartbeat.
ModuleState = Literal["starting", "ready", "stopping"]


@token_type("heartbeat")
class Heartbeat(Frozen):
    """A module's periodic sign of life: sequence, sim time [s], wall time [s], period [s], state."""

    module: str
    seq: Annotated[int, Field(ge=0)]
    sim_time: float | None = None
    wall_time: NonNeg
    period_s: Annotated[float, Field(gt=0.0)]
    pid: Annotated[int, Field(ge=0)]
    host: str = ""
    state: ModuleState = "ready"
    #: Zenoh sessions the process holds (one: every part of a process shares its session)
    zenoh_sessions: Annotated[int, Field(ge=0)] | None = None
