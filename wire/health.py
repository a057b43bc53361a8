"""The heartbeat every Sidewalk process publishes on `sidewalk/<ns>/heartbeat/<name>` (1 Hz wall).

Liveliness tokens say a process's session is up; they do not reveal a wedged process (a stopped
Python keeps its token alive). The heartbeat does: a process alive by its token whose heartbeat has
stopped is wedged. Wire form: msgpack of the model (JSON accepted on input).
"""

from __future__ import annotations

import json
import os
import resource
from typing import Literal

import msgpack
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from wire.errors import PayloadError

__all__ = ["Heartbeat", "ProcessState", "ProcessUsage", "process_usage", "encode_heartbeat", "decode_heartbeat", "HeartbeatError"]

#: Lifecycle state a process reports in its heartbeat.
ProcessState = Literal["starting", "ready", "stopping"]


class HeartbeatError(PayloadError, ValueError):
    """A heartbeat payload that does not decode; says what is wrong."""


class ProcessUsage(BaseModel):
    """What a process has cost since it started: CPU [s], resident memory [bytes], and its Zenoh traffic.

    Traffic counts what this process's session sent (puts, queries, replies) and received (samples,
    queries, replies), payload bytes only; it is cumulative, so a rate is a difference of two beats.
    `barrier_*` is the part of it on the lock-step barrier's keys: the run mode's cost, not the module's.
    """

    model_config = ConfigDict(frozen=True, extra="ignore")

    cpu_s: float = Field(ge=0.0)
    rss_bytes: int = Field(ge=0)
    msgs_out: int = Field(default=0, ge=0)
    bytes_out: int = Field(default=0, ge=0)
    msgs_in: int = Field(default=0, ge=0)
    bytes_in: int = Field(default=0, ge=0)
    barrier_msgs_out: int = Field(default=0, ge=0)
    barrier_bytes_out: int = Field(default=0, ge=0)
    barrier_msgs_in: int = Field(default=0, ge=0)
    barrier_bytes_in: int = Field(default=0, ge=0)


_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


def _rss_bytes() -> int:
    try:
        with open("/proc/self/statm", "rb") as f:
            return int(f.read().split()[1]) * _PAGE
    except (OSError, ValueError, IndexError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # peak, where /proc is missing


def process_usage(traffic: tuple[int, int, int, int] = (0, 0, 0, 0),
                  barrier: tuple[int, int, int, int] = (0, 0, 0, 0)) -> ProcessUsage:
    """Return this process's usage now, with `traffic` = (msgs_out, bytes_out, msgs_in, bytes_in), of which `barrier` on the barrier's keys."""
    ru = resource.getrusage(resource.RUSAGE_SELF)
    mo, bo, mi, bi = traffic
    bmo, bbo, bmi, bbi = barrier
    return ProcessUsage(cpu_s=ru.ru_utime + ru.ru_stime, rss_bytes=_rss_bytes(), msgs_out=mo, bytes_out=bo, msgs_in=mi, bytes_in=bi,
                        barrier_msgs_out=bmo, barrier_bytes_out=bbo, barrier_msgs_in=bmi, barrier_bytes_in=bbi)


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
    #: CPU, memory and Zenoh traffic of the process so far
    usage: ProcessUsage | None = None
    #: the process's link to the blackboard node: up, away (the node is unreachable) or resyncing
    #: (re-registering its monitors after the node came back or dropped them); None without one
    blackboard: Literal["up", "away", "resyncing"] | None = None
    #: monitors the process holds open on the blackboard
    monitors: int | None = Field(default=None, ge=0)
    #: how many times the process re-registered its monitors (the node came back or had dropped them)
    resyncs: int | None = Field(default=None, ge=0)
    #: the blackboard node's incarnation (the node only): a new value means the node restarted
    epoch: str | None = None


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
