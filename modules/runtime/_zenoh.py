"""The one file in `modules` that imports zenoh: a session bound to an asyncio loop.

Zenoh callbacks run on Zenoh threads; every sample or query is handed to the loop with
`call_soon_threadsafe` and never processed in the callback.
"""

from __future__ import annotations

import asyncio
import json
import logging
from dataclasses import dataclass
from typing import Any, Awaitable, Callable

import zenoh

from blackboard.network import NetworkConfig

__all__ = ["ZenohLink", "QueryRequest", "QueryAnswer", "GetReply"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class QueryRequest:
    """A query received by a queryable: its key, selector parameters and payload bytes."""

    key: str
    parameters: str
    payload: bytes


@dataclass(frozen=True)
class QueryAnswer:
    """The answer to a query: ok (reply) or not (reply_err), with payload bytes; key defaults to the query's.

    `replies` (key, payload) pairs, when given, are sent as ok replies instead of `payload` (a wildcard
    query answered once per matching item; none at all is a valid answer).
    """

    ok: bool
    payload: bytes = b""
    key: str | None = None
    replies: tuple[tuple[str, bytes], ...] | None = None


@dataclass(frozen=True)
class GetReply:
    """One reply to a get: the replying key (None for errors), ok flag, payload bytes."""

    key: str | None
    ok: bool
    payload: bytes


class ZenohLink:
    """A Zenoh session opened from a NetworkConfig and bound to the running asyncio loop.

    Close it explicitly with `close()` (an unclosed session hangs interpreter exit).
    """

    def __init__(self, session: Any, loop: asyncio.AbstractEventLoop) -> None:
        self._session = session
        self._loop = loop
        self._entities: list[Any] = []
        self._tasks: set[asyncio.Task[Any]] = set()
        self._closed = False

    @classmethod
    def open(cls, net: NetworkConfig) -> "ZenohLink":
        """Open a session with `net.zenoh_json()` for the running loop; raise RuntimeError on failure."""
        loop = asyncio.get_running_loop()
        try:
            session = zenoh.open(zenoh.Config.from_json5(json.dumps(net.zenoh_json())))
        except Exception as exc:  # zenoh raises ZError
            raise RuntimeError(f"cannot open Zenoh session ({net.mode}, connect={list(net.connect)}, listen={list(net.listen)}): {exc}") from exc
        return cls(session, loop)

    @property
    def closed(self) -> bool:
        """Return whether `close()` has been called."""
        return self._closed

    # ---- publish / subscribe ---------------------------------------------------------------

    def put(self, key: str, payload: bytes) -> None:
        """Publish `payload` on `key` (non-blocking)."""
        if not self._closed:
            self._session.put(key, payload)

    def subscribe(self, key_expr: str, on_sample: Callable[[str, bytes], None]) -> Any:
        """Call `on_sample(key, payload)` on the loop for every sample matching `key_expr`."""
        loop = self._loop

        def cb(sample: Any) -> None:
            key, data = str(sample.key_expr), sample.payload.to_bytes()
            try:
                loop.call_soon_threadsafe(on_sample, key, data)
            except RuntimeError:  # loop closed during shutdown
                pass

        sub = self._session.declare_subscriber(key_expr, cb)
        self._entities.append(sub)
        return sub

    # ---- liveliness ------------------------------------------------------------------------

    def declare_alive(self, key: str) -> Any:
        """Declare a liveliness token on `key` (undeclared on close)."""
        tok = self._session.liveliness().declare_token(key)
        self._entities.append(tok)
        return tok

    def watch_alive(self, key_expr: str, on_change: Callable[[str, bool], None], *, history: bool = True) -> Any:
        """Call `on_change(key, alive)` on the loop when a liveliness token appears or goes away."""
        loop = self._loop

        def cb(sample: Any) -> None:
            alive = sample.kind == zenoh.SampleKind.PUT
            try:
                loop.call_soon_threadsafe(on_change, str(sample.key_expr), alive)
            except RuntimeError:
                pass

        sub = self._session.liveliness().declare_subscriber(key_expr, cb, history=history)
        self._entities.append(sub)
        return sub

    async def alive_keys(self, key_expr: str, timeout: float = 2.0) -> list[str]:
        """Return the keys of the liveliness tokens alive under `key_expr` (timeout wall [s])."""

        def run() -> list[str]:
            return sorted(str(r.ok.key_expr) for r in self._session.liveliness().get(key_expr, timeout=timeout) if r.ok is not None)

        return await asyncio.to_thread(run)

    # ---- queries ---------------------------------------------------------------------------

    def queryable(self, key_expr: str, handler: Callable[[QueryRequest], Awaitable[QueryAnswer]]) -> Any:
        """Answer queries on `key_expr` with `await handler(request)`, run on the loop."""
        loop = self._loop

        def cb(query: Any) -> None:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            req = QueryRequest(key=str(query.key_expr), parameters=str(query.parameters), payload=payload)
            try:
                loop.call_soon_threadsafe(self._spawn_answer, query, req, handler)
            except RuntimeError:
                query.drop()

        q = self._session.declare_queryable(key_expr, cb)
        self._entities.append(q)
        return q

    def _spawn_answer(self, query: Any, req: QueryRequest, handler: Callable[[QueryRequest], Awaitable[QueryAnswer]]) -> None:
        task = self._loop.create_task(self._answer(query, req, handler))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _answer(self, query: Any, req: QueryRequest, handler: Callable[[QueryRequest], Awaitable[QueryAnswer]]) -> None:
        try:
            try:
                ans = await handler(req)
            except Exception as exc:  # a handler bug must not leave the querier hanging
                log.exception("query handler for %s failed", req.key)
                ans = QueryAnswer(ok=False, payload=f"internal error: {type(exc).__name__}: {exc}".encode())
            if self._closed:
                return
            if ans.ok and ans.replies is not None:
                for key, data in ans.replies:
                    query.reply(key, data)
            elif ans.ok:
                query.reply(ans.key or req.key, ans.payload)
            else:
                query.reply_err(ans.payload)
        finally:
            query.drop()

    async def get(self, selector: str, payload: bytes | None = None, timeout: float = 5.0) -> list[GetReply]:
        """Send a query and return every reply (timeout wall [s])."""

        def run() -> list[GetReply]:
            out = []
            kwargs: dict[str, Any] = {"timeout": timeout}
            if payload is not None:
                kwargs["payload"] = payload
            for r in self._session.get(selector, **kwargs):
                if r.ok is not None:
                    out.append(GetReply(key=str(r.ok.key_expr), ok=True, payload=r.ok.payload.to_bytes()))
                else:
                    out.append(GetReply(key=None, ok=False, payload=r.err.payload.to_bytes()))
            return out

        return await asyncio.to_thread(run)

    # ---- shutdown --------------------------------------------------------------------------

    def close(self) -> None:
        """Undeclare every entity and close the session (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for task in list(self._tasks):
            task.cancel()
        for ent in reversed(self._entities):
            try:
                ent.undeclare()
            except Exception:  # already gone with its session
                pass
        self._entities.clear()
        try:
            self._session.close()
        except Exception as exc:
            log.warning("closing the Zenoh session failed: %s", exc)

