"""Module health vocabulary: the heartbeat every module publishes (the wire's one heartbeat model)."""

from __future__ import annotations

from pydantic import ConfigDict

from modules.vocabulary._base import token_type
from wire.health import Heartbeat as _WireHeartbeat
from wire.health import ProcessState

__all__ = ["ModuleState", "Heartbeat"]

#: Lifecycle state a module reports in its heartbeat.
ModuleState = ProcessState


@token_type("heartbeat")
class Heartbeat(_WireHeartbeat):
    """A module's periodic sign of life: sequence, sim time [s], wall time [s], period [s], state."""

    model_config = ConfigDict(frozen=True, extra="forbid")
