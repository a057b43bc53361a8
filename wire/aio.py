"""The process's Zenoh session bound to an asyncio loop: samples, queries and replies handed to the loop.

Every callback from Zenoh is handed to the loop with `call_soon_threadsafe` and never processed on
the Zenoh thread. Close a `Link` explicitly with `close()`.
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from dataclasses import dataclass
from typing import Any, Awaitable, Callable

from wire.network import NetworkConfig
from wire.session import Query, Session, open_session

__all__ = ["Link", "QueryRequest", "QueryAnswer", "GetReply"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class QueryRequest:
    """A received query: its key, selector parameters, payload bytes and whether the payload is JSON."""

    key: str
    parameters: str
    payload: bytes
    is_json: bool = False


@dataclass(frozen=True)
class QueryAnswer:
    """The answer to a query: ok (reply) or not (reply_err), with payload bytes; key defaults to the query's.

    `replies` (key, payload) pairs, when given, are sent as ok replies instead of `payload` (a wildcard
    query answered once per matching item; none at all is a valid answer). `as_json` marks the
    payloads as JSON (else msgpack).
    """

    ok: bool
    payload: bytes = b""
    key: str | None = None
    replies: tuple[tuple[str, bytes], ...] | None = None
    as_json: bool = False


@dataclass(frozen=True)
class GetReply:
    """One reply to a get: the replying key (None for errors), ok flag, payload bytes, whether JSON."""

    key: str | None
    ok: bool
    payload: bytes
    is_json: bool = False


class Link:
    """A handle on the process's Zenoh session for `net`, bound to the running asyncio loop."""

    def __init__(self, session: Session, loop: asyncio.AbstractEventLoop) -> None:
        self.session = session
        self._loop = loop
        self._tasks: set[asyncio.Task[Any]] = set()
        self._closed = False

    @classmethod
    def open(cls, net: NetworkConfig) -> "Link":
        """Open (or share) the process's session for `net` on the running loop; raise wire.ConnectError on failure."""
        loop = asyncio.get_running_loop()
        return cls(open_session(net), loop)

    @property
    def net(self) -> NetworkConfig:
        """Return the network settings of the session."""
        return self.session.net

    @property
    def closed(self) -> bool:
        """Return whether `close()` has been called."""
        return self._closed

    async def wait_connected(self, timeout: float | None = None, *, name: str = "") -> None:
        """Return once the session reaches a router or peer (saying so while it waits); ConnectError after `timeout` [s]."""
        await asyncio.to_thread(self.session.wait_connected, timeout, name=name)

    # ---- publish / subscribe ---------------------------------------------------------------

    def put(self, key: str, payload: bytes, *, as_json: bool = False, attachment: bytes | None = None) -> None:
        """Publish `payload` on `key` (non-blocking; msgpack unless `as_json`), with Zenoh `attachment` bytes when given."""
        if not self._closed:
            self.session.put(key, payload, as_json=as_json, attachment=attachment)

    def subscribe_attached(self, key_expr: str, on_sample: Callable[[str, bytes, bytes | None], None]) -> Any:
        """Call `on_sample(key, payload, attachment or None)` on the loop for every sample matching `key_expr`."""
        loop = self._loop

        def cb(key: str, data: bytes, att: bytes | None) -> None:
            try:
                loop.call_soon_threadsafe(on_sample, key, data, att)
            except RuntimeError:  # loop closed during shutdown
                pass

        return self.session.subscribe_attached(key_expr, cb)

    def subscribe(self, key_expr: str, on_sample: Callable[[str, bytes], None]) -> Any:
        """Call `on_sample(key, payload)` on the loop for every sample matching `key_expr`."""
        loop = self._loop

        def cb(key: str, data: bytes) -> None:
            try:
                loop.call_soon_threadsafe(on_sample, key, data)
            except RuntimeError:  # loop closed during shutdown
                pass

        return self.session.subscribe_payload(key_expr, cb)

    def subscribe_feed(self, key_expr: str, feed: Callable[[str, bytes, asyncio.AbstractEventLoop], None]) -> Any:
        """Call `feed(key, payload, loop)` on the Zenoh thread for every sample matching `key_expr`.

        For a high-rate stream whose samples mostly need no loop work (the sim clock at a high RTF):
        `feed` must not block, and hands to the loop (`loop.call_soon_threadsafe`) only what the loop
        must do. Exceptions in `feed` are its own to report; a closed loop ends the calls quietly.
        """
        loop = self._loop

        def cb(key: str, data: bytes) -> None:
            try:
                feed(key, data, loop)
            except RuntimeError:  # loop closed during shutdown
                pass

        return self.session.subscribe_payload(key_expr, cb)

    def subscribe_newest(self, key_expr: str, newest: dict[str, tuple[bytes, float]]) -> Any:
        """Keep in `newest` the latest payload of each key matching `key_expr` and its arrival [s, time.monotonic()].

        Stored on the Zenoh thread as each sample arrives (a dict assignment, never blocking), so an
        arrival time stays true however far behind the loop is: what a watchdog of other processes needs.
        """

        def cb(key: str, data: bytes) -> None:
            newest[key] = (data, time.monotonic())

        return self.session.subscribe_payload(key_expr, cb)

    # ---- liveliness ------------------------------------------------------------------------

    def declare_alive(self, key: str) -> Any:
        """Declare a liveliness token on `key` (undeclared on close)."""
        return self.session.liveliness_token(key)

    def watch_alive(self, key_expr: str, on_change: Callable[[str, bool], None], *, history: bool = True) -> Any:
        """Call `on_change(key, alive)` on the loop when a liveliness token appears or goes away."""
        loop = self._loop

        def cb(key: str, alive: bool) -> None:
            try:
                loop.call_soon_threadsafe(on_change, key, alive)
            except RuntimeError:
                pass

        return self.session.liveliness_subscribe(key_expr, cb, history=history)

    async def alive_keys(self, key_expr: str, timeout: float = 2.0) -> list[str]:
        """Return the keys of the liveliness tokens alive under `key_expr` (timeout wall [s])."""
        return await asyncio.to_thread(self.session.liveliness_get, key_expr, timeout)

    def undeclare(self, handle: Any) -> None:
        """Undeclare something declared through this link."""
        self.session.undeclare(handle)

    # ---- queries ---------------------------------------------------------------------------

    def queryable(self, key_expr: str, handler: Callable[[QueryRequest], Awaitable[QueryAnswer]]) -> Any:
        """Answer queries on `key_expr` with `await handler(request)`, run on the loop."""
        loop = self._loop

        def cb(query: Query) -> None:
            req = QueryRequest(key=query.key, parameters=query.parameters_text, payload=query.payload, is_json=query.is_json)
            try:
                loop.call_soon_threadsafe(self._spawn_answer, query, req, handler)
            except RuntimeError:
                query.finish()

        return self.session.queryable(key_expr, cb)

    def _spawn_answer(self, query: Query, req: QueryRequest, handler: Callable[[QueryRequest], Awaitable[QueryAnswer]]) -> None:
        task = self._loop.create_task(self._answer(query, req, handler))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _answer(self, query: Query, req: QueryRequest, handler: Callable[[QueryRequest], Awaitable[QueryAnswer]]) -> None:
        try:
            try:
                ans = await handler(req)
            except Exception as exc:  # a handler bug must not leave the querier hanging
                log.exception("query handler for %s failed", req.key)
                ans = QueryAnswer(ok=False, as_json=True, payload=json.dumps(
                    {"error": "internal_error", "message": f"{type(exc).__name__}: {str(exc)[:300]}"}).encode())
            if self._closed:
                return
            if ans.ok and ans.replies is not None:
                for key, data in ans.replies:
                    query.reply(data, as_json=ans.as_json, key=key)
            elif ans.ok:
                query.reply(ans.payload, as_json=ans.as_json, key=ans.key)
            else:
                query.reply_err(ans.payload, as_json=ans.as_json)
        finally:
            query.finish()

    async def get(self, selector: str, payload: bytes | None = None, timeout: float = 5.0, *, as_json: bool = False) -> list[GetReply]:
        """Send a query and return every reply (timeout wall [s])."""
        loop = self._loop
        fut: asyncio.Future[list[GetReply]] = loop.create_future()
        out: list[GetReply] = []

        def on_reply(r: Any) -> None:
            out.append(GetReply(key=r.key, ok=r.ok, payload=r.payload, is_json=r.is_json))

        def done() -> None:
            if not fut.done():
                fut.set_result(out)

        def on_done() -> None:
            try:
                loop.call_soon_threadsafe(done)
            except RuntimeError:
                pass

        self.session.get(selector, payload, as_json=as_json, timeout=timeout, on_reply=on_reply, on_done=on_done)
        return await fut

    # ---- shutdown --------------------------------------------------------------------------

    def close(self) -> None:
        """Undeclare what this link declared and release the session (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for task in list(self._tasks):
            task.cancel()
        self.session.close()
