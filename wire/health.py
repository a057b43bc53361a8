"""The heartbeat every Sidewalk process publishes on `sidewalk/<ns>/heartbeat/<name>` (1 Hz wall).

Liveliness tokens say a process's session is up; they do not reveal a wedged process (a stopped
Python keeps its token alive). The heartbeat does: a process alive by its token whose heartbeat has
stopped is wedged. Wire form: msgpack of the model (JSON accepted on input).
"""

from __future__ import annotations

import json
from typing import Literal

import msgpack
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from wire.errors import PayloadError

__all__ = ["Heartbeat", "ProcessState", "encode_heartbeat", "decode_heartbeat", "HeartbeatError"]

#: Lifecycle state a process reports in its heartbeat.
ProcessState = Literal["starting", "ready", "stopping"]


class HeartbeatError(PayloadError, ValueError):
    """A heartbeat payload that does not decode; says what is wrong."""


class Heartbeat(BaseModel):
    """A process's periodic sign of life: name, sequence, sim time [s], wall time [s], period [s], state."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    module: str
    seq: int = Field(ge=0)
    sim_time: float | None = None
    wall_time: float = Field(ge=0.0)
    period_s: float = Field(gt=0.0)
    pid: int = Field(ge=0)
    host: str = ""
    state: ProcessState = "ready"
    #: Zenoh sessions the process holds (one: every part of a process shares its session)
    zenoh_sessions: int | None = Field(default=None, ge=0)
    #: tokens held (the blackboard node only)
    tokens: int | None = Field(default=None, ge=0)


def encode_heartbeat(hb: BaseModel) -> bytes:
    """Return the msgpack wire form of a heartbeat."""
    return msgpack.packb(hb.model_dump(mode="json", exclude_none=True))


def decode_heartbeat(payload: bytes) -> Heartbeat:
    """Return the heartbeat in a msgpack (or JSON) payload; raise HeartbeatError saying what is wrong."""
    try:
        raw = msgpack.unpackb(payload)
    except Exception:  # noqa: BLE001 - msgpack raises assorted errors on garbage
        try:
            raw = json.loads(payload)
        except ValueError:
            raise HeartbeatError(f"heartbeat payload is neither msgpack nor JSON ({len(payload)} bytes)") from None
    try:
        return Heartbeat.model_validate(raw)
    except ValidationError as exc:
        e = exc.errors()[0]
        raise HeartbeatError(f"invalid heartbeat: {'.'.join(map(str, e['loc']))}: {e['msg']}") from None
