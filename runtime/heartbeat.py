"""Heartbeats: encode/decode the periodic sign of life, and track who is beating and who went quiet."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

import msgpack

from runtime.errors import ModuleRuntimeError
from wire.health import Heartbeat, HeartbeatError, decode_heartbeat, encode_heartbeat

__all__ = ["encode_heartbeat", "decode_heartbeat", "HeartbeatError", "HeartbeatTracker", "decode_clock", "ClockPayloadError"]


class ClockPayloadError(ModuleRuntimeError, ValueError):
    """A sim clock payload that does not decode to a sim time."""


_CLOCK_FIELDS = ("stamp", "t", "sim_time", "time", "now")


def decode_clock(payload: bytes) -> float:
    """Return the sim time [s] in a clock payload: the simulator's `SimClock` map (field `stamp`), a map with
    t/sim_time/time/now, or a bare msgpack/JSON number."""
    raw: object
    try:
        raw = msgpack.unpackb(payload)
    except Exception:
        try:
            raw = json.loads(payload)
        except ValueError:
            raise ClockPayloadError(f"sim clock payload is neither msgpack nor JSON: {payload[:40]!r}") from None
    if isinstance(raw, (bytes, str)):
        try:
            raw = float(raw)
        except ValueError:
            raise ClockPayloadError(f"sim clock payload is not a number: {raw[:40]!r}") from None
    if isinstance(raw, dict):
        for name in _CLOCK_FIELDS:
            if name in raw:
                raw = raw[name]
                break
        else:
            raise ClockPayloadError(f"sim clock map has none of the fields {_CLOCK_FIELDS}: keys {sorted(map(str, raw))}")
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise ClockPayloadError(f"sim time must be a number, got {type(raw).__name__}")
    return float(raw)


@dataclass
class _Seen:
    last: Heartbeat
    wall: float


@dataclass
class HeartbeatTracker:
    """Remember the newest heartbeat of each module and say which went quiet.

    A module is stale when nothing arrived for `grace` periods of its own period (wall [s]).
    """

    grace: float = 3.0
    _seen: dict[str, _Seen] = field(default_factory=dict)

    def observe(self, hb: Heartbeat, wall: float | None = None) -> None:
        """Record a heartbeat received at wall time `wall` [s] (default: now)."""
        self._seen[hb.module] = _Seen(hb, time.monotonic() if wall is None else wall)

    def modules(self) -> tuple[str, ...]:
        """Return every module seen, sorted."""
        return tuple(sorted(self._seen))

    def last(self, module: str) -> Heartbeat | None:
        """Return the newest heartbeat of `module`, or None."""
        s = self._seen.get(module)
        return None if s is None else s.last

    def stale(self, wall: float | None = None) -> tuple[str, ...]:
        """Return the modules whose last heartbeat is older than `grace` periods at wall time `wall` [s]."""
        now = time.monotonic() if wall is None else wall
        return tuple(sorted(m for m, s in self._seen.items() if now - s.wall > self.grace * s.last.period_s))
