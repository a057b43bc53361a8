"""The one file of `vehicle_sim` that imports zenoh: a session with publishers, subscribers, queryables, gets, liveliness.

Callbacks given here run on zenoh threads: callers must not block in them (hand work to a queue).
"""

from __future__ import annotations

import json
import threading
from typing import Any, Callable

import zenoh

__all__ = ["SimSession", "SimQuery", "SimReply", "SimPublisher", "JSON", "MSGPACK"]

JSON = zenoh.Encoding.APPLICATION_JSON
MSGPACK = zenoh.Encoding("application/msgpack")


def _is_json(enc: Any) -> bool:
    return enc is not None and str(enc).startswith(("application/json", "text/json"))


class SimQuery:
    """A received query: payload bytes, whether JSON was sent, selector parameters; reply then `finish`."""

    __slots__ = ("_q", "payload", "is_json", "key", "params")

    def __init__(self, q: "zenoh.Query") -> None:
        self._q = q
        p = q.payload
        self.payload: bytes = p.to_bytes() if p is not None else b""
        self.is_json = _is_json(q.encoding)
        self.key = q.key_expr
        try:
            self.params: dict[str, str] = dict(q.parameters)
        except Exception:  # noqa: BLE001 - malformed parameters: treat as none
            self.params = {}

    def reply(self, payload: bytes, *, as_json: bool = False) -> None:
        """Send a successful reply."""
        self._q.reply(self.key, payload, encoding=JSON if as_json else MSGPACK)

    def reply_err(self, payload: bytes, *, as_json: bool = True) -> None:
        """Send an error reply."""
        self._q.reply_err(payload, encoding=JSON if as_json else MSGPACK)

    def finish(self) -> None:
        """Finalise the query (no more replies)."""
        self._q.drop()


class SimReply:
    """A reply to a get: `ok`, payload bytes, whether it is JSON."""

    __slots__ = ("ok", "payload", "is_json")

    def __init__(self, r: "zenoh.Reply") -> None:
        s = r.ok if r.ok is not None else r.err
        self.ok = r.ok is not None
        self.payload: bytes = s.payload.to_bytes()
        self.is_json = _is_json(s.encoding)


class SimPublisher:
    """A declared publisher; `put(bytes)`."""

    __slots__ = ("_p",)

    def __init__(self, p: Any) -> None:
        self._p = p

    def put(self, payload: bytes) -> None:
        """Publish one sample."""
        self._p.put(payload)


class SimSession:
    """A zenoh session opened from a zenoh-1.x JSON config dict; close it explicitly."""

    def __init__(self, zenoh_config: dict) -> None:
        self._s = zenoh.open(zenoh.Config.from_json5(json.dumps(zenoh_config)))
        self._keep: list[Any] = []
        self._closed = False
        self._lock = threading.Lock()

    def publisher(self, key: str, *, droppable: bool = False) -> SimPublisher:
        """Declare a publisher on `key` (msgpack); `droppable` publishers drop under congestion instead of blocking."""
        cc = zenoh.CongestionControl.DROP if droppable else zenoh.CongestionControl.BLOCK
        pub = self._s.declare_publisher(key, encoding=MSGPACK, congestion_control=cc, express=True)
        self._keep.append(pub)
        return SimPublisher(pub)

    def subscribe(self, key: str, on_payload: Callable[[bytes, str], None]) -> None:
        """Subscribe to `key`; `on_payload(payload, key)` runs on a zenoh thread."""
        sub = self._s.declare_subscriber(
            key, zenoh.handlers.Callback(lambda s: on_payload(s.payload.to_bytes(), str(s.key_expr)), indirect=False)
        )
        self._keep.append(sub)

    def queryable(self, key: str, on_query: Callable[[SimQuery], None]) -> None:
        """Serve queries on `key`; `on_query` runs on a zenoh thread."""
        q = self._s.declare_queryable(key, zenoh.handlers.Callback(lambda q: on_query(SimQuery(q)), indirect=False), complete=True)
        self._keep.append(q)

    def liveliness_token(self, key: str) -> None:
        """Declare a liveliness token on `key` (held until the session closes)."""
        self._keep.append(self._s.liveliness().declare_token(key))

    def liveliness_subscribe(self, key: str, on_change: Callable[[str, bool], None]) -> None:
        """Watch liveliness tokens matching `key`: `on_change(key, alive)` on a zenoh thread (current ones too)."""
        sub = self._s.liveliness().declare_subscriber(
            key,
            zenoh.handlers.Callback(lambda s: on_change(str(s.key_expr), s.kind == zenoh.SampleKind.PUT), indirect=False),
            history=True,
        )
        self._keep.append(sub)

    def get(self, selector: str, payload: bytes | None = None, *, as_json: bool = False, timeout: float = 5.0) -> list[SimReply]:
        """Query `selector` and wait for every reply (blocking; not for use inside a callback)."""
        replies = self._s.get(selector, payload=payload, encoding=JSON if as_json else MSGPACK, timeout=timeout,
                              target=zenoh.QueryTarget.BEST_MATCHING)
        return [SimReply(r) for r in replies]

    def put(self, key: str, payload: bytes, *, as_json: bool = False) -> None:
        """Publish one sample (reliable, blocking under congestion)."""
        self._s.put(key, payload, encoding=JSON if as_json else MSGPACK, congestion_control=zenoh.CongestionControl.BLOCK, express=True)

    def close(self) -> None:
        """Undeclare everything and close the session (idempotent)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        for h in reversed(self._keep):
            try:
                h.undeclare()
            except Exception:  # noqa: BLE001 - already gone
                pass
        self._keep.clear()
        self._s.close()

    def __enter__(self) -> "SimSession":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
