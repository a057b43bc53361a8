"""The one file of `blackboard` that imports zenoh: sessions, queryables, gets, pub/sub, liveliness.

Callbacks passed here run on zenoh threads; callers hand work to asyncio with
`loop.call_soon_threadsafe` and never block in them.
"""

from __future__ import annotations

import json
from typing import Any, Callable

import zenoh

from blackboard.network import NetworkConfig

__all__ = ["ZSession", "ZQuery", "ZReply", "ZSample", "open_session", "JSON", "MSGPACK"]

JSON = zenoh.Encoding.APPLICATION_JSON
MSGPACK = zenoh.Encoding("application/msgpack")
_JSON_PREFIXES = ("application/json", "text/json")


def _is_json(enc: Any) -> bool:
    return enc is not None and str(enc).startswith(_JSON_PREFIXES)


class ZQuery:
    """A received query: payload bytes, whether it is JSON, selector parameters, and replies."""

    __slots__ = ("_q", "payload", "is_json", "key")

    def __init__(self, q: "zenoh.Query") -> None:
        self._q = q
        p = q.payload
        self.payload: bytes = p.to_bytes() if p is not None else b""
        self.is_json = _is_json(q.encoding)
        self.key = q.key_expr

    def parameters(self) -> dict[str, str]:
        """Return the selector parameters (`key?a=1;b=2`) as a dict."""
        try:
            return dict(self._q.parameters)
        except Exception:  # noqa: BLE001 - malformed parameters: treat as none
            return {}

    def reply(self, payload: bytes, *, as_json: bool) -> None:
        """Send a successful reply."""
        self._q.reply(self.key, payload, encoding=JSON if as_json else MSGPACK)

    def reply_err(self, payload: bytes, *, as_json: bool) -> None:
        """Send an error reply."""
        self._q.reply_err(payload, encoding=JSON if as_json else MSGPACK)

    def finish(self) -> None:
        """Finalise the query (no more replies)."""
        self._q.drop()


class ZReply:
    """A reply to a get: ok flag, payload bytes, whether JSON."""

    __slots__ = ("ok", "payload", "is_json")

    def __init__(self, r: "zenoh.Reply") -> None:
        if r.ok is not None:
            self.ok = True
            s = r.ok
        else:
            self.ok = False
            s = r.err
        self.payload: bytes = s.payload.to_bytes()
        self.is_json = _is_json(s.encoding)


class ZSample:
    """A received sample: key, payload bytes, whether it is a delete."""

    __slots__ = ("key", "payload", "deleted")

    def __init__(self, s: "zenoh.Sample") -> None:
        self.key = str(s.key_expr)
        self.payload: bytes = s.payload.to_bytes()
        self.deleted = s.kind == zenoh.SampleKind.DELETE


class ZSession:
    """A zenoh session with the few operations the blackboard uses."""

    def __init__(self, net: NetworkConfig) -> None:
        self.net = net
        self._s = zenoh.open(zenoh.Config.from_json5(json.dumps(net.zenoh_json())))
        self._keep: list[Any] = []
        self._closed = False

    @property
    def zid(self) -> str:
        """Return this session's zenoh id."""
        return str(self._s.zid())

    def queryable(self, key: str, on_query: Callable[[ZQuery], None]) -> None:
        """Serve queries on `key`; `on_query` runs on a zenoh thread."""
        self._keep.append(
            self._s.declare_queryable(key, zenoh.handlers.Callback(lambda q: on_query(ZQuery(q)), indirect=False), complete=True)
        )

    def subscribe(self, key: str, on_sample: Callable[[ZSample], None]) -> Any:
        """Subscribe to `key`; `on_sample` runs on a zenoh thread. Return a handle for `undeclare`."""
        sub = self._s.declare_subscriber(key, zenoh.handlers.Callback(lambda s: on_sample(ZSample(s)), indirect=False))
        self._keep.append(sub)
        return sub

    def subscribe_keyed(self, key: str, on_payload: Callable[[str, bytes], None]) -> Any:
        """Subscribe to `key` where only puts are published; `on_payload(key, payload)` runs on a zenoh thread."""
        sub = self._s.declare_subscriber(
            key, zenoh.handlers.Callback(lambda s: on_payload(str(s.key_expr), s.payload.to_bytes()), indirect=False)
        )
        self._keep.append(sub)
        return sub

    def subscribe_bytes(self, key: str, on_payload: Callable[[bytes], None]) -> Any:
        """Subscribe to `key` where only puts are published; `on_payload(payload)` runs on a zenoh thread."""
        sub = self._s.declare_subscriber(key, zenoh.handlers.Callback(lambda s: on_payload(s.payload.to_bytes()), indirect=False))
        self._keep.append(sub)
        return sub

    def undeclare(self, handle: Any) -> None:
        """Undeclare a subscriber, publisher or token returned earlier."""
        try:
            self._keep.remove(handle)
        except ValueError:
            pass
        try:
            handle.undeclare()
        except Exception:  # noqa: BLE001 - already gone with the session
            pass

    def publisher(self, key: str) -> Any:
        """Declare a reliable, express publisher on `key` that blocks rather than drop (call `.put(bytes)`)."""
        pub = self._s.declare_publisher(
            key,
            encoding=MSGPACK,
            congestion_control=zenoh.CongestionControl.BLOCK,
            express=True,
            reliability=zenoh.Reliability.RELIABLE,
        )
        self._keep.append(pub)
        return pub

    def put(self, key: str, payload: bytes) -> None:
        """Publish one sample."""
        self._s.put(key, payload, encoding=MSGPACK, congestion_control=zenoh.CongestionControl.BLOCK, express=True)

    def get(
        self,
        selector: str,
        payload: bytes | None,
        *,
        as_json: bool,
        timeout: float,
        on_reply: Callable[[ZReply], None],
        on_done: Callable[[], None],
    ) -> None:
        """Send a query; `on_reply` per reply and `on_done` at the end run on zenoh threads."""
        self._s.get(
            selector,
            zenoh.handlers.Callback(lambda r: on_reply(ZReply(r)), on_done, indirect=False),
            payload=payload,
            encoding=JSON if as_json else MSGPACK,
            timeout=timeout,
            target=zenoh.QueryTarget.BEST_MATCHING,
            consolidation=zenoh.ConsolidationMode.NONE,
            congestion_control=zenoh.CongestionControl.BLOCK,
            express=True,
        )

    def liveliness_token(self, key: str) -> Any:
        """Declare a liveliness token on `key`."""
        tok = self._s.liveliness().declare_token(key)
        self._keep.append(tok)
        return tok

    def liveliness_subscribe(self, key: str, on_change: Callable[[str, bool], None], *, history: bool = False) -> Any:
        """Watch liveliness tokens under `key`; `on_change(key, alive)` runs on a zenoh thread."""
        sub = self._s.liveliness().declare_subscriber(
            key,
            zenoh.handlers.Callback(lambda s: on_change(str(s.key_expr), s.kind == zenoh.SampleKind.PUT), indirect=False),
            history=history,
        )
        self._keep.append(sub)
        return sub

    def liveliness_get(self, key: str, timeout: float) -> list[str]:
        """Return the keys of the live tokens under `key` (blocking up to `timeout` [s])."""
        out = []
        for r in self._s.liveliness().get(key, timeout=timeout):
            if r.ok is not None:
                out.append(str(r.ok.key_expr))
        return out

    def close(self) -> None:
        """Undeclare everything and close the session (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for h in reversed(self._keep):
            try:
                h.undeclare()
            except Exception:  # noqa: BLE001
                pass
        self._keep.clear()
        self._s.close()


def open_session(net: NetworkConfig) -> ZSession:
    """Open a zenoh session for `net`."""
    return ZSession(net)
