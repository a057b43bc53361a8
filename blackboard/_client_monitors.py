"""The blackboard client's monitors: `MonitorStream` (an async iterator of one spec's events) and `wait`.

A monitor is registered on the node when first used and cancelled when closed; the node's events
for it arrive with its acknowledgements (`blackboard._client_transport`) and are queued here until
consumed. After the node comes back (or says it dropped this client's monitors) the transport
re-registers every open one; events committed meanwhile are not replayed, which is why `wait`
retrieves again after each re-registration.

`_Monitors` is one part of `blackboard.client.BlackboardClient`.
"""

from __future__ import annotations

import asyncio
import collections
import itertools
import logging
from typing import TYPE_CHECKING, Any

from blackboard.codec import encode
from blackboard.errors import BlackboardError, NodeUnavailableError
from blackboard.ops import MonitorCancel, MonitorRegister
from blackboard.spec import Spec, parse_spec
from blackboard.token import MonitorEvent, Token, _trusted
from wire.ratelimit import warn_limited

if TYPE_CHECKING:
    from blackboard.client import BlackboardClient

__all__ = ["MonitorStream"]

log = logging.getLogger("blackboard.client")
_EVENT_FIELDS = {"kind", "token"}


class MonitorStream:
    """An async iterator of MonitorEvent for one spec; registered on the node until closed.

    Use `async with bb.monitor(spec) as mon: async for ev in mon: ...` (registered on entry), or
    iterate directly (registered on the first `__anext__`), or `await mon.start()`.
    """

    def __init__(self, client: "BlackboardClient", spec: Spec) -> None:
        self._client = client
        self.spec = spec
        self.mid = f"m{next(client._mids)}"
        #: events not yet consumed; None marks the end (closed)
        self._items: collections.deque[MonitorEvent | None] = collections.deque()
        #: futures of consumers waiting for an event
        self._waiters: list[asyncio.Future] = []
        self._started = False
        self._closed = False

    async def start(self) -> "MonitorStream":
        """Register the monitor on the node (idempotent); events after this are delivered."""
        if not self._started:
            self._started = True
            self._client._monitors[self.mid] = self
            await self._register()
        return self

    async def _register(self) -> None:
        c = self._client
        await c._request(c.keys.monitor, MonitorRegister.trusted(
            {"client": c.client_id, "mid": self.mid, "spec": parse_spec(self.spec), "cancel": False},
            {"client", "mid", "spec"}).wire())

    async def close(self) -> None:
        """Cancel the monitor on the node."""
        if self._closed:
            return
        self._closed = True
        self._append(None)  # ends any iteration in progress
        self._client._monitors.pop(self.mid, None)
        c = self._client
        if self._started and not c._closed and c._node_alive:  # a node that is away forgets it anyway
            try:
                await c._query_once(c.keys.monitor, encode(
                    MonitorCancel.trusted({"client": c.client_id, "mid": self.mid, "cancel": True}).wire()))
            except BlackboardError:
                pass

    async def __aenter__(self) -> "MonitorStream":
        return await self.start()

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()

    def __aiter__(self) -> "MonitorStream":
        return self

    async def __anext__(self) -> MonitorEvent:
        if not self._started and not self._closed:
            await self.start()
        items = self._items
        while not items:
            w = asyncio.get_running_loop().create_future()
            self._waiters.append(w)
            try:
                await w
            finally:
                if not w.done():
                    self._waiters.remove(w)
        ev = items[0]
        if ev is None:
            raise StopAsyncIteration  # the end marker stays: later calls end too
        items.popleft()
        return ev

    async def next(self, timeout: float | None = None) -> MonitorEvent:
        """Return the next event; raise TimeoutError after `timeout` [s] (wall clock), StopAsyncIteration once closed."""
        if timeout is None or self._items:
            return await self.__anext__()
        async with asyncio.timeout(timeout):
            return await self.__anext__()

    def _push(self, ev: MonitorEvent) -> None:
        if not self._closed:
            self._append(ev)

    def _append(self, ev: MonitorEvent | None) -> None:
        self._items.append(ev)
        if self._waiters:
            waiters, self._waiters = self._waiters, []
            for w in waiters:
                if not w.done():
                    w.set_result(None)


class _Monitors:
    """The client's open monitors: registered on the node, fed by its messages, re-registered by the transport."""

    def _init_monitors(self) -> None:
        """Start with no monitor."""
        self._monitors: dict[str, MonitorStream] = {}
        self._mids = itertools.count(1)

    @property
    def monitor_count(self) -> int:
        """Return how many monitors this client holds open."""
        return len(self._monitors)

    def _on_events(self, mid: str, evs: list) -> None:
        """Queue the node's events for monitor `mid` (one whose token this client cannot decode is skipped, with a warning)."""
        mon = self._monitors.get(mid)
        if mon is None:
            return
        for ev in evs:
            try:
                tok = self._token(ev["token"])
            except (BlackboardError, KeyError, TypeError):
                warn_limited(log, "undecodable-event", "monitor %s: an event with a token this client cannot decode", mid)
                continue
            mon._push(_trusted(MonitorEvent, {"kind": ev["kind"], "token": tok}, _EVENT_FIELDS))

    async def wait(self, spec: Spec, timeout: float | None = None) -> Token:
        """Return the first token matching `spec`, already there or still to come; TimeoutError after `timeout` [s]."""

        async def run() -> Token:
            mon = MonitorStream(self, spec)
            try:
                await mon.start()
                while True:
                    resyncs = self.resyncs
                    now = await self.retrieve(spec)
                    if now:
                        return now[0]
                    # a match posted while the monitor was not registered (the node was away) is
                    # found by retrieving again after each re-registration
                    while self.resyncs == resyncs:
                        nxt = asyncio.ensure_future(mon.__anext__())
                        back = asyncio.ensure_future(self._resync_change.wait())
                        try:
                            await asyncio.wait({nxt, back}, return_when=asyncio.FIRST_COMPLETED)
                        finally:
                            back.cancel()
                            if not nxt.done():
                                nxt.cancel()
                        if nxt.done() and not nxt.cancelled():
                            try:
                                ev = nxt.result()
                            except StopAsyncIteration:
                                raise NodeUnavailableError("client closed while waiting") from None
                            if ev.kind != "deleted":
                                return ev.token
            finally:
                await mon.close()

        return await asyncio.wait_for(run(), timeout)

    def monitor(self, spec: Spec) -> MonitorStream:
        """Return an async iterator of new/updated/deleted events of tokens matching `spec`."""
        return MonitorStream(self, spec)
