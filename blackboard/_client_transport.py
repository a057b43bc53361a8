"""The blackboard client's transport: batched writes, reads on the write channel, retries, the node's liveness.

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
are not replayed. Replies and monitor events arrive on zenoh threads and are handed to the loop
with `call_soon_threadsafe`.

`_Transport` is one part of `blackboard.client.BlackboardClient`. The node's messages carry monitor
events, handed to `_on_events` (`blackboard._client_monitors`); a node that comes back gets the open
monitors re-registered and the frame cache filled again (`_start_prime`, `blackboard._client_frames`).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
from typing import TYPE_CHECKING, Any

import msgpack
import ormsgpack

from blackboard.codec import decode, encode
from blackboard.errors import BadRequestError, BlackboardError, NodeUnavailableError, error_from_wire
from blackboard.ops import WriteOp
from wire.keys import BlackboardKeys
from wire.network import NetworkConfig
from wire.ratelimit import warn_limited
from wire.session import Reply as ZReply, Session as ZSession

if TYPE_CHECKING:
    from blackboard._client_monitors import MonitorStream
    from blackboard.frame_cache import FrameCache

__all__ = ["MAX_WRITES_PER_MESSAGE"]

log = logging.getLogger("blackboard.client")
#: msgpack packer of write batches (used on the client's loop thread only)
_packb = msgpack.Packer(use_bin_type=True).pack
#: the node's messages are decoded by ormsgpack: a 50-token retrieve reply in 31 µs where msgpack takes 59.
#: What it refuses goes to the codec's msgpack `decode`, which says what is wrong. (It does not reject
#: trailing bytes as msgpack does; it reads only what the node sends, and the node reads clients' writes with msgpack.)
_unpackb = ormsgpack.unpackb
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


class _Transport:
    """The client's link to the node: batched writes, reads and queries, retries, and the node's comings and goings."""

    net: NetworkConfig
    source: str
    keys: BlackboardKeys
    client_id: str
    timeout: float
    reconnect: bool
    frame_cache: "FrameCache | None"
    _monitors: "dict[str, MonitorStream]"

    def _init_transport(self) -> None:
        """Set the transport's state (no session: `open` makes one)."""
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
        self._closed = False
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

    def _failed(self, exc: BaseException) -> asyncio.Future:
        loop = self._loop if self._loop is not None else asyncio.get_running_loop()
        fut = loop.create_future()
        fut.set_exception(exc)
        return fut

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


class _Read:
    """A read in flight on the write channel (`[request_id, kind, body]`); resolved by its acknowledgement."""

    __slots__ = ("kind", "body", "fut")

    def __init__(self, kind: str, body: Any, fut: asyncio.Future) -> None:
        self.kind = kind
        self.body = body
        self.fut = fut


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
