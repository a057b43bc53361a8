"""Module health as an operator sees it: alive by liveliness, and beating, silent or wedged by heartbeat.

A liveliness token says a process's Zenoh session is up; it does not reveal a wedged process (a
stopped or stuck Python keeps its token). So a module alive by its token whose heartbeat is older
than `WEDGED_AFTER_S` [s] wall is reported **wedged**. A module beating but whose heartbeat says its
blackboard node is unreachable is reported **no-node** (it waits for the node, it does not work);
one re-registering its monitors after the node came back (or had dropped them) is **resyncing**.
"""

from __future__ import annotations

import asyncio
import time
from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict

from wire.aio import Link
from wire.health import Heartbeat, HeartbeatError, decode_heartbeat
from wire.keys import ModuleKeys

__all__ = ["ModuleHealth", "HealthState", "collect_heartbeats", "WEDGED_AFTER_S", "HeardBeat", "BeatLog"]

#: A live module whose newest heartbeat is older than this [s] wall is wedged.
WEDGED_AFTER_S = 3.0

HealthState = Literal["starting", "ready", "stopping", "wedged", "silent", "no-node", "resyncing"]


class HeardBeat(BaseModel):
    """A heartbeat and the wall time [s] it was received."""

    model_config = ConfigDict(frozen=True)

    beat: Heartbeat
    received: float


class ModuleHealth(BaseModel):
    """One live module: its state, heartbeat age [s] wall, host and pid (from its heartbeat)."""

    model_config = ConfigDict(frozen=True)

    name: str
    state: HealthState
    heartbeat_age_s: Optional[float] = None
    host: str = ""
    pid: Optional[int] = None
    sim_time: Optional[float] = None
    #: its link to the blackboard node ("up", "away", "resyncing"; None: it has none or did not say)
    blackboard: Optional[str] = None
    #: monitors it holds open on the blackboard, and how often it re-registered them
    monitors: Optional[int] = None
    resyncs: Optional[int] = None

    @classmethod
    def judge(cls, name: str, heard: HeardBeat | None, now: float, *, listened_s: float,
              wedged_after_s: float = WEDGED_AFTER_S) -> "ModuleHealth":
        """Judge a module alive by liveliness from its newest heartbeat (None: none heard in `listened_s` [s])."""
        if heard is None:
            # silent for the whole listening window: wedged if that window was long enough to tell
            return cls(name=name, state="wedged" if listened_s >= wedged_after_s else "silent")
        age = max(0.0, now - heard.received)
        b = heard.beat
        state: HealthState = b.state
        if age > wedged_after_s:
            state = "wedged"
        elif b.state == "ready" and b.blackboard == "away":
            state = "no-node"
        elif b.state == "ready" and b.blackboard == "resyncing":
            state = "resyncing"
        return cls(name=name, state=state, heartbeat_age_s=round(age, 3), host=b.host, pid=b.pid, sim_time=b.sim_time,
                   blackboard=b.blackboard, monitors=b.monitors, resyncs=b.resyncs)


async def collect_heartbeats(link: Link, keys: ModuleKeys, expect: set[str], wait_s: float) -> dict[str, HeardBeat]:
    """Listen to every heartbeat for up to `wait_s` [s] wall, returning early once each of `expect` was heard."""
    heard: dict[str, HeardBeat] = {}
    done = asyncio.Event()

    def on_beat(key: str, payload: bytes) -> None:
        try:
            hb = decode_heartbeat(payload)
        except HeartbeatError:
            return
        heard[key.rsplit("/", 1)[-1]] = HeardBeat(beat=hb, received=time.time())
        if expect <= set(heard):
            done.set()

    sub = link.subscribe(keys.heartbeat_all, on_beat)
    try:
        if expect:
            try:
                await asyncio.wait_for(done.wait(), wait_s)
            except asyncio.TimeoutError:
                pass
    finally:
        link.undeclare(sub)
    return heard


class BeatLog:
    """Remember, per process name, the pid and the arrival [s, time.monotonic] of its newest heartbeat.

    Arrivals are stamped on the Zenoh thread, not when the loop gets round to the sample: a busy or
    starved loop must not make a silent process look as if it had just beaten (issue 14).
    """

    def __init__(self, link: Link, keys: ModuleKeys) -> None:
        self._link = link
        self._keys = keys
        self._raw: dict[str, tuple[bytes, float]] = {}
        self._decoded: dict[str, tuple[bytes, int | None]] = {}
        self._sub = link.subscribe_newest(keys.heartbeat_all, self._raw)

    def newest(self, name: str) -> tuple[int, float] | None:
        """Return (pid, time.monotonic() [s]) of the newest heartbeat heard from `name` (None: none, or undecodable)."""
        key = self._keys.heartbeat(name)
        heard = self._raw.get(key)
        if heard is None:
            return None
        payload, arrived = heard
        seen = self._decoded.get(key)
        if seen is None or seen[0] is not payload:
            try:
                pid: int | None = decode_heartbeat(payload).pid
            except HeartbeatError:
                pid = None
            seen = self._decoded[key] = (payload, pid)
        return None if seen[1] is None else (seen[1], arrived)

    def close(self) -> None:
        """Stop listening."""
        if not self._link.closed:
            self._link.undeclare(self._sub)
