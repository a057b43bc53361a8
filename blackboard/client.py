"""The async blackboard client every module uses.

Writes issued in the same loop iteration are coalesced into one batch message (one commit on the
node), at most `MAX_WRITES_PER_MESSAGE` to a message: a full message leaves at once, so the node
commits it while the client is still issuing the rest (a stream of posts keeps both processes busy
instead of taking turns). Each call still gets its own acknowledgement or typed error. A write resolves once the node
has committed it (durable per the node's sync mode). Write batches travel as puts on
`bb/write/<client>` (`[request_id, ops]`); after each commit the node publishes one message on
`bb/to/<client>` with this client's acknowledgements (`[request_id, results]`) and the events of
its monitors. A batch not acknowledged within `timeout` [s] while the node is up is sent again (the
node answers a batch it already committed from its acknowledgement cache), waiting twice as long
each time; after `_WRITE_TRIES` sends it fails with NodeUnavailableError. A retrieve travels the
same way, `[request_id, "retrieve", request]` on `bb/write/<client>`, its tokens coming back as its
acknowledgement: it is answered after every write this client made before it, and a put answered
by a put costs less in Zenoh than a query (on two cores a raw relay took about 300 µs p50 where a
raw get took 400).

The node may go away (killed, restarted, a link down) and come back: while its liveliness token is
gone, writes and queries are held (a warning says so every `_WAIT_WARN_S` [s]) and batches in
flight are kept; once it is back the client re-registers every open monitor, then re-sends what it
held (a batch in flight when the node died may have been committed: it is sent again, so a post
may be stored twice). A node that dropped this client's monitors (its liveliness lease expired,
e.g. while the process was stopped) says so with a resync notice when the client's token comes
back, and the client re-registers them too. Events committed while a monitor was not registered
are not replayed. `post`, `post_raw`, `post_pose` and
`set_static_frame` queue their request when called and return an awaitable future (so
`asyncio.gather(*[bb.post(...) for ...])` pipelines without a task per post); `update`, `delete`,
`retrieve`, `wait`, `lookup_pose` and `transform` are coroutines. Replies and monitor events
arrive on zenoh threads and are handed to the loop with `call_soon_threadsafe`.
"""

from __future__ import annotations

import asyncio
import collections
import itertools
import logging
import re
import uuid
from typing import Any

import msgpack
import numpy as np
import ormsgpack
from pydantic import BaseModel

from wire.session import Reply as ZReply, Session as ZSession, open_session
from blackboard.codec import decode, encode
from blackboard.errors import BadRequestError, BlackboardError, NodeUnavailableError, error_from_wire
from blackboard.frame_cache import FrameCache
from blackboard.geometry import Point, Polygon, Polyline, Pose2D
from wire.keys import BlackboardKeys
from wire.network import NetworkConfig
from blackboard.ops import (
    DeleteOp,
    LookupRequest,
    MonitorCancel,
    MonitorRegister,
    PoseOp,
    PostOp,
    RetrieveRequest,
    StaticOp,
    UpdateOp,
    WriteOp,
)
from blackboard.registry import TypeRegistry, default_registry
from blackboard.replies import FrameListing, NodeStats
from blackboard.spec import Spec, parse_spec
from blackboard.token import MonitorEvent, Token, _geom_from_wire, _trusted, make_token, token_from_owned_wire
from wire.ratelimit import warn_limited
from wire.se2 import transform_points

__all__ = ["BlackboardClient", "MonitorStream", "MAX_WRITES_PER_MESSAGE"]

log = logging.getLogger("blackboard.client")
#: msgpack packer of write batches (used on the client's loop thread only)
_packb = msgpack.Packer(use_bin_type=True).pack
#: the node's messages are decoded by ormsgpack: a 50-token retrieve reply in 31 µs where msgpack takes 59.
#: What it refuses goes to the codec's msgpack `decode`, which says what is wrong. (It does not reject
#: trailing bytes as msgpack does; it reads only what the node sends, and the node reads clients' writes with msgpack.)
_unpackb = ormsgpack.unpackb
_SAFE = re.compile(r"[^A-Za-z0-9_-]")
_EVENT_FIELDS = {"kind", "token"}
_POSE_FIELDS = {"x", "y", "yaw"}
#: every field of a PostOp, as its fields set (one set shared by all: a frozen model's is never changed in place)
_POST_FIELDS = set(PostOp.model_fields)
#: while the node is away, warn this often [s] wall that requests are held
_WAIT_WARN_S = 5.0
#: a write batch unacknowledged while the node is up is sent this many times, the wait doubling
#: each time (10 + 20 + 40 s with the default timeout), before it fails
_WRITE_TRIES = 3
#: the most writes one batch message carries [-]. One message is one commit on the node, acknowledged
#: whole; without a bound a burst of posts went out as one message, and client and node took turns
#: (the node committing, the client waiting; then the client resolving, the node idle). 64–512
#: measured alike on two cores (about 1.7× the posts a second of one unbounded message).
MAX_WRITES_PER_MESSAGE = 256


def _geom_wire(g: Point | Polyline | Polygon | None) -> dict | None:
    if g is None:
        return None
    if isinstance(g, Point):
        return {"kind": "point", "x": g.x, "y": g.y}
    if isinstance(g, (Polyline, Polygon)):
        return {"kind": g.kind, "points": [list(p) for p in g.points]}
    if isinstance(g, dict):
        return g
    raise TypeError(f"geometry must be Point, Polyline, Polygon or None, not {type(g).__name__}")


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


class BlackboardClient:
    """Async client of a blackboard node in `net.namespace`."""

    def __init__(
        self,
        net: NetworkConfig,
        *,
        source: str = "anonymous",
        registry: TypeRegistry | None = None,
        timeout: float = 10.0,
        connect_timeout: float = 10.0,
        lenient: bool = False,
        reconnect: bool = True,
        frame_cache: bool = False,
    ) -> None:
        self.net = net
        #: hold requests while the node is away and re-send them once it is back (False: fail them at once)
        self.reconnect = reconnect
        self.source = source
        self.registry = registry if registry is not None else default_registry
        self.timeout = timeout
        self.connect_timeout = connect_timeout
        #: keep attrs of types missing from the registry as plain dicts instead of raising UnknownTypeError
        self.lenient = lenient
        self.keys = BlackboardKeys(net.namespace)
        self.client_id = (_SAFE.sub("_", source)[:24] or "c") + "-" + uuid.uuid4().hex[:10]
        self._session: ZSession | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._batch: list[tuple[WriteOp, asyncio.Future, Any]] = []
        self._batch_scheduled = False
        #: write batches (and reads, `_Read`) sent and not yet acknowledged: request id → (batch, deadline [loop time, s]),
        #: in sending order (so in deadline order); one timer sweeps the expired ones
        self._inflight: dict[int, tuple["list[tuple[WriteOp, asyncio.Future, Any]] | _Read", float]] = {}
        self._sweeper: asyncio.TimerHandle | None = None
        self._rids = itertools.count(1)
        self._wpub: Any = None
        self._monitors: dict[str, MonitorStream] = {}
        self._mids = itertools.count(1)
        self._closed = False
        self._spec_cache: dict[int, tuple[Spec, dict]] = {}
        #: whether the node's liveliness token is up; `_node_change` is set (and replaced) on each change
        self._node_alive = False
        self._node_change = asyncio.Event()
        #: whether the node was seen up once (a later "up" is a return: monitors are re-registered)
        self._node_seen = False
        #: write batches held while the node is away, in sending order: (request id, batch)
        self._held: list[tuple[int, "list[tuple[WriteOp, asyncio.Future, Any]] | _Read"]] = []
        self._resync_task: asyncio.Task | None = None
        #: request id → how many times its batch was sent (only for those sent more than once)
        self._tries: dict[int, int] = {}
        #: how many times monitors were re-registered after the node came back or dropped them
        self.resyncs = 0
        self._resync_change = asyncio.Event()
        #: loop time [s] the node was last seen going away (None: it is up)
        self._lost_at: float | None = None
        #: a copy of the node's frame tree answering lookups here (`blackboard.frame_cache`; None: ask the node)
        self.frame_cache: FrameCache | None = FrameCache() if frame_cache else None
        self._prime_task: asyncio.Task | None = None
        self._frames_change = asyncio.Event()

    # ------------------------------------------------------------------ lifecycle
    @classmethod
    async def connect(cls, net: NetworkConfig, **kw: Any) -> "BlackboardClient":
        """Open a client and wait until the node is reachable (NodeUnavailableError after connect_timeout)."""
        self = cls(net, **kw)
        await self.open()
        return self

    async def open(self) -> None:
        """Open the zenoh session, declare this client's liveliness and wait for the node."""
        self._loop = loop = asyncio.get_running_loop()
        self._session = s = await loop.run_in_executor(None, open_session, self.net)
        s.liveliness_token(self.keys.client_alive(self.client_id))
        on_message = self._on_message
        s.subscribe_payload(self.keys.to_client(self.client_id), lambda _key, payload: loop.call_soon_threadsafe(on_message, payload))
        self._wpub = s.publisher(self.keys.write(self.client_id))
        if self.frame_cache is not None:  # subscribed before the whole tree is asked for: nothing falls between
            on_frames = self._on_frames_update
            s.subscribe_payload(self.keys.frame_updates, lambda _key, payload: loop.call_soon_threadsafe(on_frames, payload))
        s.liveliness_subscribe(self.keys.alive, lambda _key, alive: loop.call_soon_threadsafe(self._on_node, alive), history=True)
        try:
            await self.wait_node(timeout=self.connect_timeout)
        except (asyncio.TimeoutError, TimeoutError):
            await self.close()
            raise NodeUnavailableError(
                f"no blackboard node in namespace {self.net.namespace!r} within {self.connect_timeout} s "
                f"(endpoints {list(self.net.connect or self.net.listen)})"
            ) from None
        if self.frame_cache is not None:
            await self._prime_frames()

    async def close(self) -> None:
        """Cancel monitors, fail outstanding requests and close the session."""
        if self._closed:
            return
        for mon in list(self._monitors.values()):
            await mon.close()
        self._closed = True
        for _, fut, _ in self._batch:
            if not fut.done():
                fut.set_exception(NodeUnavailableError("client closed"))
        self._batch.clear()
        held, self._held = self._held, []
        for _, batch in held:
            _distribute(batch, None, NodeUnavailableError("client closed"))
        if self._resync_task is not None:
            self._resync_task.cancel()
        if self._prime_task is not None:
            self._prime_task.cancel()
        self._fail_inflight(NodeUnavailableError("client closed"))
        if self._session is not None:
            s, self._session = self._session, None
            s.close()

    async def __aenter__(self) -> "BlackboardClient":
        await self.open()
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()

    # ------------------------------------------------------------------ transport
    async def _query(self, selector: str, payload: bytes | None, as_json: bool = False) -> Any:
        """Ask the node; while it is away wait for it (warning every `_WAIT_WARN_S` [s]) and ask again."""
        while True:
            await self._until_node(selector)
            try:
                return await self._query_once(selector, payload, as_json)
            except NodeUnavailableError:
                if self._closed or self._node_alive or not self.reconnect:
                    raise
                # the node went away while we asked: ask again once it is back

    async def _until_node(self, what: str) -> None:
        """Return once the node is up; warn every `_WAIT_WARN_S` [s] while waiting."""
        waited = 0.0
        while not self._node_alive and self.reconnect:
            if self._closed:
                raise NodeUnavailableError("client is closed")
            try:
                await self.wait_node(timeout=_WAIT_WARN_S)
            except (asyncio.TimeoutError, TimeoutError):
                waited += _WAIT_WARN_S
                log.warning("%s: blackboard node in namespace %r unreachable for %.0f s; %s waits for it",
                            self.source, self.net.namespace, waited, what)

    def _query_once(self, selector: str, payload: bytes | None, as_json: bool = False) -> asyncio.Future:
        loop = self._loop
        assert loop is not None
        if self._session is None:
            raise NodeUnavailableError("client is closed")
        fut: asyncio.Future = loop.create_future()

        def on_reply(r: ZReply) -> None:
            loop.call_soon_threadsafe(_resolve, fut, r)

        def on_done() -> None:
            loop.call_soon_threadsafe(_finish, fut, selector)

        self._session.get(selector, payload, as_json=as_json, timeout=self.timeout, on_reply=on_reply, on_done=on_done)
        return fut

    async def _request(self, key: str, obj: Any, *, selector: str | None = None) -> Any:
        return await self._query(selector or key, encode(obj))

    def _write(self, op: WriteOp, then: Any = None) -> asyncio.Future:
        """Queue one write; return a future of its result (`then(result)` if given)."""
        loop = self._loop
        if loop is None:
            raise NodeUnavailableError("client not opened")
        fut = loop.create_future()
        if self._closed:
            fut.set_exception(NodeUnavailableError("client is closed"))
            return fut
        batch = self._batch
        batch.append((op, fut, then))
        if len(batch) >= MAX_WRITES_PER_MESSAGE:
            self._batch = []
            self._send(batch)
        if not self._batch_scheduled:
            # the first write of a loop iteration goes out at once; later ones in the same
            # iteration are coalesced into batches, each sent once full, the last at the iteration's end
            self._batch_scheduled = True
            self._send_batch(reschedule=True)
        return fut

    def _send_batch(self, reschedule: bool = False) -> None:
        batch, self._batch = self._batch, []
        if reschedule:
            assert self._loop is not None
            self._loop.call_soon(self._send_batch)
        else:
            self._batch_scheduled = False
        if batch:
            self._send(batch)

    def _send(self, batch: "list[tuple[WriteOp, asyncio.Future, Any]] | _Read") -> None:
        """Send one write batch (or read) under a new request id (or hold it while the node is away)."""
        if self._session is None or self._wpub is None:
            _distribute(batch, None, NodeUnavailableError("client is closed"))
            return
        rid = next(self._rids)
        if not self._node_alive and self._node_seen and self.reconnect:
            self._held.append((rid, batch))  # sent once the node is back
            return
        self._put_batch(rid, batch)

    def _put_batch(self, rid: int, batch: "list[tuple[WriteOp, asyncio.Future, Any]] | _Read", timeout: float | None = None) -> None:
        try:
            if type(batch) is _Read:
                data = _packb((rid, batch.kind, batch.body))
            else:
                data = _packb((rid, [e[0].wire() for e in batch]))
        except Exception as exc:  # noqa: BLE001 - e.g. an attribute msgpack cannot carry
            what = batch.kind if type(batch) is _Read else "write"
            _distribute(batch, None, BadRequestError(f"cannot encode {what}: {type(exc).__name__}: {exc}"[:300]))
            return
        loop = self._loop
        assert loop is not None and self._wpub is not None
        self._inflight[rid] = (batch, loop.time() + (timeout or self.timeout))
        if self._sweeper is None:
            self._sweeper = loop.call_later(timeout or self.timeout, self._sweep)
        self._wpub.put(data)

    def _on_message(self, payload: bytes) -> None:
        """Handle one node message `[acks, events]`: deliver monitor events, then resolve acknowledged writes."""
        try:
            try:
                msg = _unpackb(payload)  # the common case, without the codec's error wrapping
            except Exception:  # noqa: BLE001 - let the codec say what is wrong
                msg = decode(payload)
            acks, events = msg[0], msg[1]
            if len(msg) > 2 and msg[2] == "resync":
                self._start_resync("the node dropped this client's monitors")
            for mid, evs in events:
                self._on_events(mid, evs)
            if acks:
                if events:  # monitor consumers woken above run first, then the writers
                    assert self._loop is not None
                    self._loop.call_soon(self._on_acks, acks)
                else:
                    self._on_acks(acks)
        except (BlackboardError, TypeError, ValueError):
            warn_limited(log, "malformed-message", "malformed message from the node on %s", self.keys.to_client(self.client_id))

    def _on_acks(self, acks: list) -> None:
        try:
            for rid, results in acks:
                self._on_ack(rid, results)
        except (TypeError, ValueError):
            warn_limited(log, "malformed-ack", "malformed acknowledgement from the node on %s", self.keys.to_client(self.client_id))

    def _on_ack(self, rid: Any, results: Any) -> None:
        """Resolve the futures of the write batch `rid` with its results (a list, or one error object)."""
        entry = self._inflight.pop(rid, None) if type(rid) is int else None
        if self._tries:
            self._tries.pop(rid, None)
        if entry is None:
            return  # already timed out, or not ours
        batch = entry[0]
        if isinstance(results, dict):
            _distribute(batch, None, error_from_wire(results))
        else:
            _distribute(batch, results, None)

    def _sweep(self) -> None:
        """Fail the write batches whose deadline passed; re-arm for the earliest one left."""
        self._sweeper = None
        loop = self._loop
        assert loop is not None
        now = loop.time()
        inflight = self._inflight
        while inflight:
            rid = next(iter(inflight))
            batch, deadline = inflight[rid]
            if deadline > now:
                self._sweeper = loop.call_at(deadline, self._sweep)
                break
            del inflight[rid]
            tries = self._tries.get(rid, 1)
            read = type(batch) is _Read
            if tries >= _WRITE_TRIES or not self.reconnect:
                self._tries.pop(rid, None)
                _distribute(batch, None, NodeUnavailableError(
                    f"no {'reply' if read else 'acknowledgement'} from the blackboard node after {tries} tries over "
                    f"{self.timeout * (2 ** tries - 1):.0f} s (namespace {self.net.namespace!r})"
                    + ("" if read else "; the write may or may not have been stored")))
                continue
            self._tries[rid] = tries + 1
            log.warning("%s: no %s of %s %d within %.0f s; sending it again", self.source,
                        "reply" if read else "acknowledgement", batch.kind if read else "write batch", rid,
                        self.timeout * 2 ** (tries - 1))
            # the node answers a batch it already committed from its acknowledgement cache
            self._put_batch(rid, batch, timeout=self.timeout * 2 ** tries)

    # ------------------------------------------------------------------ frame cache
    def _on_frames_update(self, payload: bytes) -> None:
        cache = self.frame_cache
        assert cache is not None
        try:
            msg = _unpackb(payload)
        except Exception:  # noqa: BLE001 - a malformed update: the cache fetches the whole tree again
            warn_limited(log, "malformed-frames", "malformed frame update on %s", self.keys.frame_updates)
            msg = None
        if not cache.update(msg):
            self._start_prime()

    def _start_prime(self) -> None:
        if self._closed or not self._node_alive or (self._prime_task is not None and not self._prime_task.done()):
            return
        assert self._loop is not None
        self._prime_task = self._loop.create_task(self._prime_frames())

    async def _prime_frames(self) -> None:
        """Fetch the node's whole frame tree into the cache; lookups go to the node until it holds one."""
        cache = self.frame_cache
        assert cache is not None
        for _ in range(5):  # a fetch overtaken by a gap in the updates is fetched again
            if self._closed or not self._node_alive:
                return
            try:
                history = await self._query(self.keys.frame_history, None)
                if cache.prime(history):
                    change, self._frames_change = self._frames_change, asyncio.Event()
                    change.set()
                    return
            except BlackboardError as exc:
                warn_limited(log, "frame-history", "%s: frame cache not filled, lookups go to the node: %s", self.source, exc)
                return
        log.warning("%s: frame cache: updates kept breaking off while fetching the tree; lookups go to the node", self.source)

    async def wait_frame_cache(self, primes: int, *, timeout: float | None = None) -> None:
        """Return once the frame cache holds a tree fetched `primes` times in all; TimeoutError after `timeout` [s] wall."""
        cache = self.frame_cache
        if cache is None:
            raise BadRequestError("this client keeps no frame cache (frame_cache=False)")
        async with asyncio.timeout(timeout):
            while not (cache.ready and cache.stats.primes >= primes):
                await self._frames_change.wait()

    def _on_node(self, alive: bool) -> None:
        if alive == self._node_alive:
            return
        self._node_alive = alive
        loop = self._loop
        assert loop is not None
        if not alive:
            self._lost_at = loop.time()
            if self.frame_cache is not None:
                self.frame_cache.invalidate("the node went away")
            self._node_gone()
        elif self._node_seen and not self._closed:
            self._start_resync("the node came back", restart=True)
        self._node_seen = self._node_seen or alive
        change, self._node_change = self._node_change, asyncio.Event()
        change.set()

    def _start_resync(self, why: str, *, restart: bool = False) -> None:
        running = self._resync_task is not None and not self._resync_task.done()
        if self._closed or (running and not restart):
            return
        if running:
            self._resync_task.cancel()  # the node went away again meanwhile: register everything anew
        assert self._loop is not None
        self._resync_task = self._loop.create_task(self._resync(why))

    async def _resync(self, why: str) -> None:
        """Re-register every open monitor, then send the writes held while the node was away."""
        loop = self._loop
        assert loop is not None
        t0 = loop.time()
        mons = [m for m in self._monitors.values() if m._started and not m._closed]
        failed = 0
        for m in mons:
            try:
                await m._register()
            except BlackboardError as exc:
                failed += 1
                log.warning("%s: could not re-register monitor %s (%s): %s", self.source, m.mid, m.spec, exc)
        held, self._held = self._held, []
        if self._node_alive:
            for rid, batch in held:
                self._put_batch(rid, batch)
        else:
            self._held = held + self._held
        if self.frame_cache is not None and not self.frame_cache.ready:
            self._start_prime()
        self.resyncs += 1
        change, self._resync_change = self._resync_change, asyncio.Event()
        change.set()
        away = f" after {t0 - self._lost_at:.1f} s away" if self._lost_at is not None else ""
        self._lost_at = None
        log.warning("%s: blackboard node %s%s: re-registered %d monitors (%d failed), re-sent %d write batches in %.2f s",
                    self.source, why.removeprefix("the node "), away, len(mons) - failed, failed, len(held), loop.time() - t0)

    async def wait_node(self, alive: bool = True, *, timeout: float | None = None) -> None:
        """Return once the node's liveliness token is up (`alive`) or gone; TimeoutError after `timeout` [s] wall."""
        async with asyncio.timeout(timeout):
            while self._node_alive != alive:
                await self._node_change.wait()

    @property
    def link_state(self) -> str:
        """Return "up", "away" (the node is unreachable) or "resyncing" (re-registering monitors)."""
        if not self._node_alive:
            return "away"
        if self._resync_task is not None and not self._resync_task.done():
            return "resyncing"
        return "up"

    @property
    def monitor_count(self) -> int:
        """Return how many monitors this client holds open."""
        return len(self._monitors)

    @property
    def awaiting_acks(self) -> bool:
        """Return whether a write batch sent waits for its acknowledgement (a lock-step participant's busy probe)."""
        return bool(self._inflight)

    async def wait_resyncs(self, count: int, *, timeout: float | None = None) -> None:
        """Return once monitors were re-registered `count` times in all; TimeoutError after `timeout` [s] wall."""
        async with asyncio.timeout(timeout):
            while self.resyncs < count:
                await self._resync_change.wait()

    def _node_gone(self) -> None:
        """Hold every unacknowledged write to re-send once the node is back (without `reconnect`: fail them)."""
        if not self.reconnect:
            self._fail_inflight(NodeUnavailableError(
                f"the blackboard node in namespace {self.net.namespace!r} went away before acknowledging; "
                "the write may or may not have been stored"))
            return
        log.warning("%s: the blackboard node in namespace %r went away; holding requests until it is back",
                    self.source, self.net.namespace)
        inflight, self._inflight = self._inflight, {}
        if self._sweeper is not None:
            self._sweeper.cancel()
            self._sweeper = None
        self._held = [(rid, batch) for rid, (batch, _) in inflight.items()] + self._held

    def _fail_inflight(self, exc: BlackboardError) -> None:
        inflight, self._inflight = self._inflight, {}
        if self._sweeper is not None:
            self._sweeper.cancel()
            self._sweeper = None
        for batch, _ in inflight.values():
            _distribute(batch, None, exc)

    def _on_events(self, mid: str, evs: list) -> None:
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

    # ------------------------------------------------------------------ tokens
    def _token(self, w: dict, attrs: Any = None) -> Token:
        """Build the Token of a just-decoded wire dict (it becomes the token's fields)."""
        if attrs is None:
            if self.lenient and w["type"] not in self.registry:
                attrs = w["attrs"]
            else:
                attrs = self.registry.decode(w["type"], w["attrs"])
        return token_from_owned_wire(w, attrs)

    def _tokens(self, ws: list[dict]) -> list[Token]:
        """Build the Tokens of just-decoded wire dicts (they become the tokens' fields) as `_token` does,
        each type's attrs decoder looked up once."""
        decoders: dict[str, Any] = {}
        out = []
        for w in ws:
            typ = w["type"]
            dec = decoders.get(typ)
            if dec is None:
                dec = decoders[typ] = (_same if self.lenient and typ not in self.registry else self.registry.decoder(typ))
            out.append(token_from_owned_wire(w, dec(w["attrs"])))
        return out

    def _spec_wire(self, spec: Spec) -> dict:
        hit = self._spec_cache.get(id(spec))
        if hit is not None and hit[0] is spec:
            return hit[1]
        if isinstance(spec, dict):
            return spec
        w = spec.model_dump(mode="json")
        if len(self._spec_cache) > 256:
            self._spec_cache.clear()
        self._spec_cache[id(spec)] = (spec, w)
        return w

    def post(
        self,
        attrs: BaseModel,
        *,
        frame: str = "world",
        geometry: Point | Polyline | Polygon | None = None,
        stamp: float,
        type: str | None = None,
    ) -> "asyncio.Future[Token]":
        """Post a token; its type is the model's registered name. Await the Token (id, version 1).

        The request is queued when called (posts go out in call order; those made in the same loop
        iteration share one message and one commit, `MAX_WRITES_PER_MESSAGE` at most); the returned
        future resolves on the ack.
        """
        try:
            name = type or self.registry.name_of(attrs)
            g = _geom_wire(geometry)
            op = PostOp.trusted({
                "op": "post",
                "type": name,
                "attrs": attrs.__pydantic_serializer__.to_python(attrs, mode="json"),
                "frame": frame,
                "stamp": stamp,
                "source": self.source,
                "geometry": g,
                "reply": "id",
            }, _POST_FIELDS)
        except Exception as exc:  # noqa: BLE001 - raised when awaited, like any other failure
            return self._failed(exc)
        geom = _geom_from_wire(g) if isinstance(geometry, dict) else geometry
        source = self.source
        return self._write(op, lambda tid: make_token(tid, name, 1, float(stamp), source, frame, geom, attrs))

    def _failed(self, exc: BaseException) -> asyncio.Future:
        loop = self._loop if self._loop is not None else asyncio.get_running_loop()
        fut = loop.create_future()
        fut.set_exception(exc)
        return fut

    def post_raw(
        self, type: str, attrs: dict, *, frame: str = "world", geometry: Any = None, stamp: float = 0.0
    ) -> "asyncio.Future[dict]":
        """Post a token from a raw attribute dict (validated by the node); await its wire dict."""
        try:
            g = _geom_wire(geometry)
        except Exception as exc:  # noqa: BLE001
            return self._failed(exc)
        return self._write(PostOp.trusted({"op": "post", "type": type, "attrs": attrs, "frame": frame, "stamp": stamp,
                                           "source": self.source, "geometry": g, "reply": None}, _POST_FIELDS))

    async def update(
        self,
        token_id: str,
        attrs: BaseModel | None = None,
        *,
        expected_version: int,
        geometry: Point | Polyline | Polygon | None | type(...) = ...,  # type: ignore[valid-type]
        stamp: float | None = None,
        frame: str | None = None,
    ) -> Token:
        """Replace a token's attrs/geometry/stamp/frame if it is still at `expected_version` (CAS).

        Raise VersionConflictError if someone else updated it first, NotFoundError if it is gone.
        """
        fields: dict[str, Any] = {"op": "update", "id": token_id, "expected_version": expected_version,
                                  "attrs": None, "frame": frame, "stamp": stamp, "geometry": None}
        given = {"op", "id", "expected_version"}
        if attrs is not None:
            fields["attrs"] = attrs.model_dump(mode="json")
            given.add("attrs")
        if geometry is not ...:
            fields["geometry"] = _geom_wire(geometry)  # type: ignore[arg-type]
            given.add("geometry")
        given.update(k for k in ("stamp", "frame") if fields[k] is not None)
        w = await self._write(UpdateOp.trusted(fields, given))
        return self._token(w, attrs)

    async def delete(self, token_id: str, *, expected_version: int | None = None) -> None:
        """Delete a token (optionally only if at `expected_version`)."""
        given = {"op", "id"} | ({"expected_version"} if expected_version is not None else set())
        await self._write(DeleteOp.trusted({"op": "delete", "id": token_id, "expected_version": expected_version}, given))

    async def retrieve_raw(self, spec: Spec | dict, *, frame: str | None = None, frame_stamp: float | None = None) -> list[dict]:
        """Return the matching tokens as wire dicts (attrs not decoded)."""
        # the body is the spec itself, or {"spec", "frame", "frame_stamp"} (docs/keys.md); the node validates it
        body: Any = self._spec_wire(spec)
        if frame is not None or frame_stamp is not None:
            req = RetrieveRequest.parse({"spec": spec, "frame": frame, "frame_stamp": frame_stamp})
            body = {"spec": body, "frame": req.frame, "frame_stamp": req.frame_stamp}
        return await self._read("retrieve", body)

    async def _read(self, kind: str, body: Any) -> Any:
        """Send a read on the write channel after this client's queued writes; return its result."""
        await self._until_node(kind)
        loop = self._loop
        if loop is None:
            raise NodeUnavailableError("client not opened")
        if self._closed or self._session is None:
            raise NodeUnavailableError("client is closed")
        if self._batch:  # writes queued before the read go first: it sees them
            batch, self._batch = self._batch, []
            self._send(batch)
        read = _Read(kind, body, loop.create_future())
        self._send(read)  # under its own request id, held while the node is away, as a write batch
        return await read.fut

    async def retrieve(self, spec: Spec, *, frame: str | None = None, frame_stamp: float | None = None) -> list[Token]:
        """Return the tokens matching `spec`; geometry in `frame` (at `frame_stamp`, default each token's stamp)."""
        return self._tokens(await self.retrieve_raw(spec, frame=frame, frame_stamp=frame_stamp))

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

    # ------------------------------------------------------------------ frames
    def post_pose(self, *, parent: str, child: str, pose: Pose2D, stamp: float, hold: float | None = 0.0) -> "asyncio.Future[None]":
        """Record child's pose in parent at `stamp` [s]; `hold` [s] keeps the newest valid that long (None: forever).

        Queued when called, like `post`; await the returned future for the ack.
        """
        return self._write(PoseOp.trusted({"op": "pose", "parent": parent, "child": child, "pose": pose.as_tuple(),
                                           "stamp": stamp, "hold": hold}))

    def set_static_frame(self, *, parent: str, child: str, pose: Pose2D) -> "asyncio.Future[None]":
        """Fix `child` in `parent` for all times (e.g. a sensor on the vehicle); await the ack."""
        return self._write(StaticOp.trusted({"op": "static", "parent": parent, "child": child, "pose": pose.as_tuple()}))

    async def lookup(self, target: str, target_stamp: float | None, source: str, source_stamp: float | None) -> Pose2D:
        """Return T_{target@target_stamp ← source@source_stamp} (None stamp: newest).

        With a frame cache (`frame_cache=True`) answered here when the cached tree can, else by the node.
        """
        if self.frame_cache is not None:
            T = self.frame_cache.lookup(target, target_stamp, source, source_stamp)
            if T is not None:
                return _trusted(Pose2D, {"x": T[0], "y": T[1], "yaw": T[2]}, _POSE_FIELDS)
        x, y, yaw = await self._node_lookup(target, target_stamp, source, source_stamp)
        return _trusted(Pose2D, {"x": x, "y": y, "yaw": yaw}, _POSE_FIELDS)

    async def _node_lookup(self, target: str, target_stamp: float | None, source: str, source_stamp: float | None) -> tuple[float, float, float]:
        x, y, yaw = await self._request(self.keys.lookup, LookupRequest.trusted(
            {"target": target, "target_stamp": target_stamp, "source": source, "source_stamp": source_stamp}).wire())
        return (x, y, yaw)

    async def lookup_pose(self, *, parent: str, child: str, stamp: float | None = None) -> Pose2D:
        """Return the pose of `child` in `parent` at `stamp` [s] (None: newest)."""
        if stamp is None:
            return await self.lookup(parent, None, child, None)
        return await self.lookup(parent, stamp, child, stamp)

    async def transform(
        self,
        points: np.ndarray,
        *,
        src_frame: str,
        src_stamp: float | None,
        dst_frame: str,
        dst_stamp: float | None = None,
    ) -> np.ndarray:
        """Map (N,2) float64 points [m] from `src_frame@src_stamp` to `dst_frame@dst_stamp` (None: src_stamp)."""
        dst_at = src_stamp if dst_stamp is None else dst_stamp
        if self.frame_cache is not None:
            T3 = self.frame_cache.lookup(dst_frame, dst_at, src_frame, src_stamp)
            if T3 is not None:
                return transform_points(T3, points)
        return transform_points(await self._node_lookup(dst_frame, dst_at, src_frame, src_stamp), points)

    async def frames(self) -> FrameListing:
        """Return the node's frame tree (edges; oldest and newest stamps [s] of moving ones)."""
        return FrameListing.model_validate(await self._query(self.keys.frames, None))

    async def stats(self) -> NodeStats:
        """Return the node's counters (posts, retrieves, monitors, events, bytes in/out, tokens, …)."""
        return NodeStats.model_validate(await self._query(self.keys.stats, None))


class _Read:
    """A read in flight on the write channel (`[request_id, kind, body]`); resolved by its acknowledgement."""

    __slots__ = ("kind", "body", "fut")

    def __init__(self, kind: str, body: Any, fut: asyncio.Future) -> None:
        self.kind = kind
        self.body = body
        self.fut = fut


def _same(x: Any) -> Any:
    return x


def _distribute(batch: "list[tuple[WriteOp, asyncio.Future, Any]] | _Read", results: Any, exc: BaseException | None) -> None:
    if type(batch) is _Read:
        fut = batch.fut
        if fut.done():
            return
        if exc is None and type(results) is not list:
            exc = NodeUnavailableError(f"malformed {batch.kind} reply: {str(results)[:200]}")
        if exc is not None:
            fut.set_exception(exc)
        else:
            fut.set_result(results)
        return
    if exc is None and (not isinstance(results, list) or len(results) != len(batch)):
        exc = NodeUnavailableError(f"malformed batch reply: {str(results)[:200]}")
    if exc is not None:
        for _, fut, _ in batch:
            if not fut.done():
                fut.set_exception(exc)
        return
    for (_, fut, then), res in zip(batch, results):
        if fut.done():
            continue
        if "ok" in res:
            if then is None:
                fut.set_result(res["ok"])
            else:
                try:
                    fut.set_result(then(res["ok"]))
                except Exception as e:  # noqa: BLE001
                    fut.set_exception(e)
        else:
            fut.set_exception(error_from_wire(res))


def _resolve(fut: asyncio.Future, r: ZReply) -> None:
    if fut.done():
        return
    try:
        obj = decode(r.payload, as_json=r.is_json)
    except BlackboardError as exc:
        fut.set_exception(exc)
        return
    if r.ok:
        fut.set_result(obj)
    else:
        fut.set_exception(error_from_wire(obj))


def _finish(fut: asyncio.Future, selector: str) -> None:
    if not fut.done():
        fut.set_exception(NodeUnavailableError(f"no reply from the blackboard node to {selector}"))


