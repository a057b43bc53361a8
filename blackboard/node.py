"""The blackboard node: answers Zenoh queries on `sidewalk/<ns>/bb/…`; an asyncio loop runs its life.

Clients write on a put channel: a batch `[request_id, ops]` published on `bb/write/<client>`.
After the commit the node publishes one message per client on `bb/to/<client>`: `[acks, events]`,
the acknowledgements `[request_id, results]` of that client's batches and the events of its
monitors (a put relayed by the node costs less in zenoh than a query answered by it, and one
message per client per commit wakes the client once). The queryables `bb/post|batch|update|delete`
serve the same writes to standard Zenoh tools (JSON or msgpack). A client retrieves on the same
channel, `[request_id, "retrieve", request]`, answered after the writes sent before it as an
acknowledgement whose result is the list of tokens (or one error object); `bb/retrieve` serves
the same to standard tools.

Requests go into one inbox. Whoever drains it holds the state lock; it takes every request
waiting, applies consecutive writes in one transaction (group commit), publishes monitor events
right after the commit, then acknowledges them; reads are answered in arrival order from
committed state (pending writes are committed first, so a client reads its own writes).

Dispatch modes:
- `"loop"`: zenoh callbacks hand the request to the asyncio loop with `call_soon_threadsafe`
  and the loop drains the inbox.
- `"inline"` (default): the zenoh callback that finds the lock free drains the inbox itself
  (try-acquire, never waits: a callback that finds it taken just leaves its request for the
  current drainer, which re-checks the inbox after releasing). This saves a thread hand-off
  per request — measured on the 2-core box: a raw get answered in the callback took 127 µs p50,
  answered after a hop to an asyncio loop 247 µs — which the issue's latency ratios cannot absorb.
  The work done in the callback is bounded CPU work plus the journal append of the commit (a
  `write` to the page cache; SQLite catches up in batches, see `blackboard.store`); nothing waits
  on another thread or on the network.
  With `sync="full"` every commit fsyncs, which would block the callback, so the node then uses
  `"loop"` whatever was asked.
"""

from __future__ import annotations

import asyncio
import collections
import gc
import logging
import threading
import os
import socket
import signal
import sys
import time
import uuid
from typing import Any, Callable, Literal

import msgpack

from wire.session import Query as ZQuery, Session as ZSession, open_session, session_stats, barrier_traffic, traffic
from blackboard.codec import MAX_PAYLOAD, decode, encode, pack_array_of_packed
from blackboard.core import BlackboardCore, Monitor
from blackboard.errors import BadRequestError, BlackboardError
from blackboard.frames import FrameTree
from blackboard.ops import FramesRequest, LookupRequest, MonitorCancel, RetrieveRequest, StatsRequest, parse_monitor
from wire.health import Heartbeat, encode_heartbeat, process_usage
from wire.keys import BlackboardKeys
from wire.lifeline import dump_stacks_on_request
from wire.lockstep import Participant, lockstep_enabled, participant_name
from wire.network import NetworkConfig
from blackboard.registry import TypeRegistry, default_registry
from blackboard.store import Store, SyncMode
from wire.ratelimit import warn_limited

__all__ = ["BlackboardNode", "serve"]

log = logging.getLogger("blackboard.node")
_packb = msgpack.Packer(use_bin_type=True).pack
_unpackb = msgpack.unpackb
#: msgpack of the map head and keys of a monitor event {"kind": …, "token": …} (the token follows)
_EV_HEAD = {kind: b"\x82\xa4kind" + _packb(kind) + b"\xa5token" for kind in ("new", "updated", "deleted")}
#: settle journaled writes into SQLite this long after the first unsettled commit [s] …
_SETTLE_DELAY = 0.05
#: … or at once when this many statements and index changes wait
_SETTLE_NOW = 1_000
#: most clients whose publishers are kept declared (the earliest declared is dropped first)
_MAX_CLIENT_PUBLISHERS = 4096
#: acknowledgements kept per client, so a batch sent again (its ack was lost) is not applied twice
_ACK_CACHE = 64
#: most clients whose dropped monitors are remembered (to tell them to re-register on return)
_MAX_DROPPED = 4096
#: the node process's collector thresholds: a batch of 1,000 posts allocates some 20,000 containers and keeps
#: about 2,000; at Python's default (700, 10, 10) most of a batch's temporaries were promoted to the oldest
#: generation and full collections ran every few batches, each scanning every token (6-13 µs per post at
#: 40,000-120,000 tokens, measured); at these they run about once per 100,000 posts
_GC_THRESHOLDS = (20_000, 20, 10)


class _Packed(bytes):
    """A result already msgpack-encoded (a retrieve's token list): an acknowledgement carries it as it is."""


class _Ack:
    """Where a put-channel write request is acknowledged: the client id and its request id."""

    __slots__ = ("client", "rid")

    def __init__(self, client: str, rid: Any) -> None:
        self.client = client
        self.rid = rid


class BlackboardNode:
    """Serve one blackboard (store + frame tree) over Zenoh in namespace `net.namespace`."""

    def __init__(
        self,
        net: NetworkConfig,
        *,
        db: str = ":memory:",
        sync: SyncMode = "normal",
        registry: TypeRegistry | None = None,
        frames: FrameTree | None = None,
        heartbeat_period: float = 1.0,
        dispatch: Literal["inline", "loop"] = "inline",
        test_hold_after_journal: str | None = None,
        client_confirm_s: float = 15.0,
    ) -> None:
        if dispatch not in ("inline", "loop"):
            raise ValueError(f"dispatch must be 'inline' or 'loop', not {dispatch!r}")
        if sync == "full" and dispatch == "inline":
            # an fsync per commit would block the Zenoh callback thread: hand requests to the loop
            log.info("--sync full: dispatching requests on the asyncio loop, not in Zenoh callbacks")
            dispatch = "loop"
        self.net = net
        self.keys = BlackboardKeys(net.namespace)
        self.store = Store(db, sync=sync)
        self.core = BlackboardCore(self.store, registry if registry is not None else default_registry, frames)
        self.heartbeat_period = heartbeat_period
        self._hb_seq = 0
        #: this node's incarnation, in its heartbeat: a client (or an operator) sees a restart as a new value
        self.epoch = uuid.uuid4().hex[:12]
        self._session: ZSession | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self.dispatch = dispatch
        #: writes waiting for the next commit: (query or put-channel ack target, ops, single op?)
        self._pending: list[tuple[ZQuery | _Ack, list[Any], bool]] = []
        #: (handler, args, is it a write?)
        self._inbox: collections.deque[tuple[Callable[..., None], tuple, bool]] = collections.deque()
        self._lock = threading.Lock()
        self._closing = False
        self._write_handlers = {self._on_post, self._on_update, self._on_delete, self._on_batch}
        #: declared publishers on `bb/to/<client>`, kept while the client lives
        self._client_pubs: dict[str, Any] = {}
        self._settle_scheduled = False
        #: this node life's name and the number of its last commit that changed frames, as published on
        #: `bb/frames/updates` (a client's frame cache sees a gap or a new life and asks for the whole tree)
        self._frame_epoch = uuid.uuid4().hex[:12]
        self._frame_seq = 0
        self._frame_pub: Any = None
        #: client → its newest acknowledgements (request id → results), oldest first
        self._acked: dict[str, collections.OrderedDict[Any, Any]] = {}
        #: clients whose monitors were dropped when their liveliness token went (told to resync on return)
        self._dropped: dict[str, None] = {}
        #: clients back after their monitors were dropped: every message to them carries the resync
        #: notice until they register a monitor again (a notice may reach a client before its subscriber)
        self._resync_due: dict[str, None] = {}
        #: clients whose liveliness token is alive now
        self._live_clients: set[str] = set()
        #: clients holding monitors that never declared liveliness: when [s, time.monotonic] first seen;
        #: their monitors are reclaimed after `client_confirm_s` [s] wall (nobody would ever drop them)
        self._unconfirmed: dict[str, float] = {}
        self.client_confirm_s = client_confirm_s
        #: test hook (durability tests only): hold after a commit's journal append while this file exists
        self._hold_path = test_hold_after_journal
        self._stop = asyncio.Event()
        self.ready = asyncio.Event()

    # ------------------------------------------------------------------ lifecycle
    async def run(self, on_ready: Callable[[], None] | None = None) -> None:
        """Serve until `stop()` (or SIGINT/SIGTERM when installed by `serve`)."""
        self._loop = asyncio.get_running_loop()
        s = self._session = open_session(self.net)
        try:
            k = self.keys
            handlers: dict[str, Callable[[ZQuery], None]] = {
                k.post: self._on_post,
                k.batch: self._on_batch,
                k.update: self._on_update,
                k.delete: self._on_delete,
                k.retrieve: self._on_retrieve,
                k.lookup: self._on_lookup,
                k.frames: self._on_frames,
                k.frame_history: self._on_frame_history,
                k.monitor: self._on_monitor,
                k.stats: self._on_stats,
            }
            self._frame_pub = s.publisher(k.frame_updates)
            for key, h in handlers.items():
                s.queryable(key, lambda q, h=h, w=h in self._write_handlers: self._submit(self._guard, (h, q), w))
            s.subscribe_payload(f"{k.write_prefix}/*", lambda key, payload: self._submit(self._on_write, (key, payload), True))
            s.liveliness_subscribe(
                f"{k.client_alive_prefix}/*",
                lambda key, alive: self._submit(self._client_back if alive else self._client_gone, (key,), False),
                history=True,  # clients alive before this node started count as alive (their monitors are kept)
            )
            participant = None
            if lockstep_enabled():  # the simulator's barrier waits until no request is queued or being applied
                participant = Participant(s, participant_name("blackboard"))
                participant.add_probe(lambda: self._lock.locked() or bool(self._inbox) or bool(self._pending))
            s.liveliness_token(k.alive)
            hb = asyncio.create_task(self._heartbeat())
            self.ready.set()
            if on_ready is not None:
                on_ready()
            await self._stop.wait()
            hb.cancel()
            if participant is not None:
                participant.close()
        finally:
            self.close()

    def stop(self) -> None:
        """Ask `run` to return (thread-safe)."""
        if self._loop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)

    def close(self) -> None:
        """Close the zenoh session (no new requests), finish what is queued, close the store."""
        if self._session is not None:
            self._session.close()
        with self._lock:
            self._closing = True
            self._process_inbox()
            self._session = None
            self.store.close()

    async def _heartbeat(self) -> None:
        s = self._session
        assert s is not None
        while True:
            self._hb_seq += 1
            s.put(self.keys.heartbeat, encode_heartbeat(Heartbeat(
                module="blackboard", seq=self._hb_seq, wall_time=time.time(), period_s=self.heartbeat_period,
                pid=os.getpid(), host=socket.gethostname(), tokens=len(self.store), zenoh_sessions=session_stats()["open"],
                usage=process_usage(traffic(), barrier_traffic()), epoch=self.epoch)))
            if self._unconfirmed:
                self._submit(self._reclaim_unconfirmed, (), False)
            await asyncio.sleep(self.heartbeat_period)

    # ------------------------------------------------------------------ dispatch
    def _submit(self, fn: Callable[..., None], args: tuple, write: bool) -> None:
        """Queue a request (any thread) and get it drained per the dispatch mode."""
        self._inbox.append((fn, args, write))
        if self.dispatch == "inline":
            self._drain()
        elif self._loop is not None:
            self._loop.call_soon_threadsafe(self._drain)

    def _drain(self) -> None:
        """Drain the inbox if nobody else is (never waits for the lock)."""
        while self._inbox and not self._closing:
            if not self._lock.acquire(blocking=False):
                return  # the holder re-checks the inbox after releasing
            t0 = time.perf_counter()
            try:
                if not self._closing:
                    self._process_inbox()
            finally:
                self.core.stats.busy_us += int((time.perf_counter() - t0) * 1e6)
                self._lock.release()

    def _process_inbox(self) -> None:
        inbox = self._inbox
        while inbox:
            fn, args, write = inbox.popleft()
            if not write:
                self._flush()  # reads and admin see every write that arrived before them
            try:
                fn(*args)
            except Exception:  # noqa: BLE001 - the node must keep serving
                log.exception("request failed")
        self._flush()

    def _guard(self, handler: Callable[[ZQuery], None], q: ZQuery) -> None:
        """Run a query handler; answer a BlackboardError (or any failure) with a typed error reply."""
        self.core.stats.bytes_in += len(q.payload)
        try:
            handler(q)
        except BlackboardError as exc:
            self.core.stats.errors += 1
            self._reply_err(q, exc.to_wire())
        except Exception as exc:  # noqa: BLE001 - the node must keep serving
            log.exception("internal error answering %s", q.key)
            self.core.stats.errors += 1
            self._reply_err(q, _unexpected(exc, "internal error"))

    def _reply(self, q: ZQuery, obj: Any) -> None:
        data = encode(obj, as_json=q.is_json)
        self.core.stats.bytes_out += len(data)
        try:
            q.reply(data, as_json=q.is_json)
        finally:
            q.finish()

    def _reply_bytes(self, q: ZQuery, data: bytes) -> None:
        self.core.stats.bytes_out += len(data)
        try:
            q.reply(data, as_json=False)
        finally:
            q.finish()

    def _reply_err(self, q: ZQuery, obj: dict) -> None:
        data = encode(obj, as_json=q.is_json)
        self.core.stats.bytes_out += len(data)
        try:
            q.reply_err(data, as_json=q.is_json)
        except Exception:  # noqa: BLE001 - the querier may be gone
            log.debug("could not send error reply", exc_info=True)
        finally:
            q.finish()

    def _body(self, q: ZQuery, *, empty: Any = None) -> Any:
        if not q.payload:
            if empty is not None:
                return empty
            raise BadRequestError(f"{q.key}: empty payload")
        return decode(q.payload, as_json=q.is_json)

    # writes ----------------------------------------------------------------
    def _enqueue(self, q: ZQuery, ops: list[Any], single: bool) -> None:
        self._pending.append((q, ops, single))

    def _on_write(self, key: str, payload: bytes) -> None:
        """Queue a put-channel write batch `[request_id, ops]` from client `key`'s last chunk."""
        stats = self.core.stats
        stats.bytes_in += len(payload)
        client = key[key.rfind("/") + 1 :]
        try:
            try:
                if len(payload) > MAX_PAYLOAD:
                    raise ValueError("too large")
                msg = _unpackb(payload)  # the common case, without the codec's error wrapping
            except Exception:  # noqa: BLE001 - let the codec say what is wrong
                msg = decode(payload)
        except BlackboardError as exc:
            stats.errors += 1
            warn_limited(log, "undecodable-batch", "undecodable write batch from %s: %.200s", client, exc.message)
            return
        if type(msg) is list and len(msg) == 3 and type(msg[1]) is str:
            self._on_read(client, msg[0], msg[1], msg[2])
            return
        if type(msg) is not list or len(msg) != 2:
            stats.errors += 1
            warn_limited(log, "malformed-batch", "write batch from %s is not [request_id, ops]: %.200r", client, msg)
            return
        rid, ops = msg
        done = self._acked.get(client)
        if done is not None and type(rid) is int and rid in done:
            self._deliver({client: [(rid, done[rid])]}, {})  # sent again: its ack was lost
            return
        if type(ops) is not list:
            stats.errors += 1
            self._deliver({client: [(rid, BadRequestError(f"{key}: ops must be a list of operations").to_wire())]}, {})
            return
        self._pending.append((_Ack(client, rid), ops, False))

    def _on_read(self, client: str, rid: Any, kind: str, body: Any) -> None:
        """Answer a put-channel read `[request_id, kind, request]` after the writes that came before it."""
        self._flush()
        res: Any
        try:
            if kind != "retrieve":
                raise BadRequestError(f"unknown read {kind!r} on the write channel (takes \"retrieve\")"[:200])
            res = _Packed(self.core.retrieve_packed(RetrieveRequest.from_wire(body, {})))
        except BlackboardError as exc:
            self.core.stats.errors += 1
            res = exc.to_wire()
        except Exception as exc:  # noqa: BLE001 - the node must keep serving
            log.exception("internal error answering a read from %s", client)
            self.core.stats.errors += 1
            res = _unexpected(exc, "internal error")
        self._deliver({client: [(rid, res)]}, {})

    def _on_post(self, q: ZQuery) -> None:
        self._enqueue(q, [self._single_op(q, "post")], True)

    def _on_update(self, q: ZQuery) -> None:
        self._enqueue(q, [self._single_op(q, "update")], True)

    def _on_delete(self, q: ZQuery) -> None:
        self._enqueue(q, [self._single_op(q, "delete")], True)

    def _single_op(self, q: ZQuery, kind: str) -> Any:
        """Return the body of a one-operation queryable tagged as `kind` (validated in the commit)."""
        op = self._body(q)
        if type(op) is not dict:
            raise BadRequestError(f"{q.key}: payload must be an object (one {kind} operation)")
        if op.get("op", kind) != kind:
            raise BadRequestError(f"{q.key}: takes a {kind} operation, not {op.get('op')!r}"[:200])
        return {**op, "op": kind}

    def _on_batch(self, q: ZQuery) -> None:
        ops = self._body(q)
        if not isinstance(ops, list):
            raise BadRequestError(f"{q.key}: payload must be a list of operations")
        self._enqueue(q, ops, False)

    def _flush(self) -> None:
        pending, self._pending = self._pending, []
        if not pending:
            return
        try:
            results, changes = self.core.apply_requests([p[1] for p in pending])
        except Exception as exc:  # noqa: BLE001 - e.g. disk full: nothing acknowledged
            log.exception("commit failed")
            err = _unexpected(exc, "commit failed")
            acks: dict[str, list] = {}
            for q, _, _ in pending:
                if type(q) is _Ack:
                    acks.setdefault(q.client, []).append((q.rid, err))
                else:
                    self._reply_err(q, err)
            self._deliver(acks, {})
            return
        if self._hold_path is not None:
            self._hold_after_journal(self._hold_path)
        self._publish_frames()  # before the acks: a client told of a commit has its frames already
        events: dict[str, dict[str, list[bytes]]] = {}
        if self.core.monitors:
            try:
                events = self._events(self.core.match_records(changes))
            except Exception:  # noqa: BLE001 - acks must still go out
                log.exception("monitor matching failed")
        acks = {}
        queries = []
        for (q, _, single), res in zip(pending, results):
            if type(q) is _Ack:
                acks.setdefault(q.client, []).append((q.rid, res))
            else:
                queries.append((q, single, res))
        self._deliver(acks, events)  # monitor events and put-channel acks: one message per client
        for client, done in acks.items():  # remembered after sending (still under the lock a re-sent batch waits for)
            for rid, res in done:
                self._remember_ack(client, rid, res)
        for q, single, res in queries:
            try:
                if single:
                    r = res[0]
                    if "ok" in r:
                        self._reply(q, r["ok"])
                    else:
                        self._reply_err(q, r)
                else:
                    self._reply(q, res)
            except Exception:  # noqa: BLE001 - a vanished querier must not stop the others
                log.debug("reply failed", exc_info=True)
        self._after_commit()

    def _publish_frames(self) -> None:
        """Publish the frame changes of the commit just made as `[epoch, seq, changes]` (see `BlackboardCore.frame_log`)."""
        changes = self.core.take_frame_log()
        if not changes or self._frame_pub is None:
            return
        self._frame_seq += 1
        data = _packb([self._frame_epoch, self._frame_seq, changes])
        self.core.stats.bytes_out += len(data)
        try:
            self._frame_pub.put(data)
        except Exception:  # noqa: BLE001 - a cache that misses it sees the gap and asks for the whole tree
            log.warning("could not publish frame changes %d", self._frame_seq, exc_info=True)

    def _remember_ack(self, client: str, rid: Any, res: Any) -> None:
        if type(rid) is not int:
            return
        done = self._acked.get(client)
        if done is None:
            if len(self._acked) >= _MAX_CLIENT_PUBLISHERS:
                self._acked.pop(next(iter(self._acked)))
            done = self._acked[client] = collections.OrderedDict()
        done[rid] = res
        if len(done) > _ACK_CACHE:
            done.popitem(last=False)

    @staticmethod
    def _hold_after_journal(path: str) -> None:
        """Test hook: with the commit journaled and nothing acknowledged, hold while `path` exists.

        Creates `path + ".held"` first, so a test knows the node stands between the journal write
        and the acknowledgement (and can SIGKILL it there). Active only with --test-hold-after-journal.
        """
        if not os.path.exists(path):
            return
        with open(path + ".held", "w"):
            pass
        while os.path.exists(path):
            time.sleep(0.005)

    def _after_commit(self) -> None:
        """Get the journaled writes into SQLite soon: at once past `_SETTLE_NOW`, else after `_SETTLE_DELAY`.

        Settling in batches keeps SQLite's per-transaction cost out of each write (reads that need
        SQLite settle first; the journal keeps everything acknowledged durable meanwhile).
        """
        if self.store.unsettled() >= _SETTLE_NOW or self._loop is None:
            self.store.settle()
        elif not self._settle_scheduled:
            self._settle_scheduled = True
            loop = self._loop
            loop.call_soon_threadsafe(loop.call_later, _SETTLE_DELAY, self._submit, self._settle, (), False)

    def _settle(self) -> None:
        self._settle_scheduled = False
        self.store.settle()

    @staticmethod
    def _events(matches: list[tuple[Monitor, str, Any]]) -> dict[str, dict[str, list[bytes]]]:
        """Group matched events by client and monitor (commit order kept); encode each event once."""
        out: dict[str, dict[str, list[bytes]]] = {}
        packed: dict[tuple[str, int], bytes] = {}
        for m, kind, rec in matches:
            pk = (kind, id(rec))
            ev = packed.get(pk)
            if ev is None:
                ev = packed[pk] = _EV_HEAD[kind] + rec.packed()
            out.setdefault(m.client, {}).setdefault(m.mid, []).append(ev)
        return out

    def _deliver(self, acks: dict[str, list], events: dict[str, dict[str, list[bytes]]]) -> None:
        """Publish `[acks, events]` on `bb/to/<client>` for every client with something (events first).

        A client due to re-register its monitors gets `[acks, events, "resync"]`, with or without something else.
        """
        s = self._session
        if s is None:
            return
        order = list(events) + [c for c in acks if c not in events]
        notice = self._resync_due
        if notice:
            order += [c for c in notice if c not in events and c not in acks]
        for client in order:
            a = acks.get(client)
            ev = events.get(client)
            note = "resync" if notice and client in notice else None
            try:
                head = (b"\x92" if note is None else b"\x93") + (_pack_acks(a) if a else b"\x90")
            except Exception:  # noqa: BLE001 - a request id msgpack cannot echo back (a foreign writer)
                warn_limited(log, "ack-encode", "cannot encode the acknowledgement for %s", client)
                continue
            data = head + (
                pack_array_of_packed([b"\x92" + _packb(mid) + pack_array_of_packed(evs) for mid, evs in ev.items()])
                if ev else b"\x90"
            ) + (b"" if note is None else _packb(note))
            pub = self._client_pubs.get(client)
            if pub is None:
                if len(self._client_pubs) >= _MAX_CLIENT_PUBLISHERS:
                    s.undeclare(self._client_pubs.pop(next(iter(self._client_pubs))))
                pub = self._client_pubs[client] = s.publisher(self.keys.to_client(client))
            self.core.stats.bytes_out += len(data)
            try:
                pub.put(data)
            except Exception:  # noqa: BLE001 - one client's failure must not stop the others
                log.warning("could not publish to client %s", client, exc_info=True)

    # reads -----------------------------------------------------------------
    def _on_retrieve(self, q: ZQuery) -> None:
        req = RetrieveRequest.from_wire(self._body(q, empty={}), q.parameters)
        if q.is_json:
            self._reply(q, self.core.retrieve(req))
        else:
            self._reply_bytes(q, self.core.retrieve_packed(req))

    def _on_lookup(self, q: ZQuery) -> None:
        self._reply(q, self.core.lookup(LookupRequest.parse(self._body(q))))

    def _on_frames(self, q: ZQuery) -> None:
        FramesRequest.parse(self._body(q, empty={}))
        self._reply(q, self.core.frame_info().wire())

    def _on_frame_history(self, q: ZQuery) -> None:
        FramesRequest.parse(self._body(q, empty={}))
        self._reply(q, {"epoch": self._frame_epoch, "seq": self._frame_seq, **self.core.frame_history()})

    def _on_stats(self, q: ZQuery) -> None:
        StatsRequest.parse(self._body(q, empty={}))
        self._reply(q, self.core.stats_snapshot().model_dump())

    def _on_monitor(self, q: ZQuery) -> None:
        req = parse_monitor(self._body(q))
        if type(req) is MonitorCancel:
            self._reply(q, {"cancelled": self.core.cancel_monitor(req.client, req.mid)})
            return
        self.core.register_monitor(req.client, req.mid, req.spec)
        self._resync_due.pop(req.client, None)
        if req.client not in self._live_clients:
            self._unconfirmed.setdefault(req.client, time.monotonic())
        self._reply(q, {"registered": req.mid})

    def _reclaim_unconfirmed(self) -> None:
        """Drop the monitors of clients that never declared liveliness within `client_confirm_s` [s]."""
        now = time.monotonic()
        for client, since in list(self._unconfirmed.items()):
            if client in self._live_clients:
                del self._unconfirmed[client]
            elif now - since >= self.client_confirm_s:
                del self._unconfirmed[client]
                n = self.core.drop_client(client)
                pub = self._client_pubs.pop(client, None)
                if pub is not None and self._session is not None:
                    self._session.undeclare(pub)
                self._acked.pop(client, None)
                if n:
                    warn_limited(log, "unconfirmed-client", "client %s never declared liveliness in %.0f s: reclaimed its %d monitors",
                                 client, self.client_confirm_s, n)

    def _client_gone(self, key: str) -> None:
        client = key.rsplit("/", 1)[-1]
        self._live_clients.discard(client)
        n = self.core.drop_client(client)
        pub = self._client_pubs.pop(client, None)
        if pub is not None and self._session is not None:
            self._session.undeclare(pub)
        self._acked.pop(client, None)
        self._resync_due.pop(client, None)
        if n:
            log.info("client %s gone: dropped %d monitors", client, n)
            if len(self._dropped) >= _MAX_DROPPED:
                self._dropped.pop(next(iter(self._dropped)))
            self._dropped[client] = None

    def _client_back(self, key: str) -> None:
        """Tell a client whose monitors were dropped while its token was gone to register them again."""
        client = key.rsplit("/", 1)[-1]
        self._live_clients.add(client)
        self._unconfirmed.pop(client, None)
        if client in self._dropped and self._session is not None:
            del self._dropped[client]
            self._resync_due[client] = None
            log.info("client %s is back: asking it to re-register its monitors", client)
            self._deliver({}, {})


def _unexpected(exc: BaseException, what: str) -> dict:
    """Return the wire error object for a failure that is no BlackboardError (`what`: where it happened)."""
    return {"error": "blackboard_error", "message": f"{what}: {type(exc).__name__}: {exc}"[:300]}


def _pack_acks(acks: list) -> bytes:
    """Encode `[[request_id, result], …]`, a `_Packed` result spliced in as it is."""
    for _, res in acks:
        if type(res) is _Packed:
            return pack_array_of_packed([b"\x92" + _packb(rid) + (r if type(r) is _Packed else _packb(r)) for rid, r in acks])
    return _packb(acks)


def serve(
    net: NetworkConfig,
    *,
    db: str = ":memory:",
    sync: SyncMode = "normal",
    types: tuple[str, ...] = (),
    registry: TypeRegistry | None = None,
    history: float = 60.0,
    dispatch: Literal["inline", "loop"] = "inline",
    ready_stream: Any = None,
    test_hold_after_journal: str | None = None,
) -> None:
    """Run a node until SIGINT/SIGTERM; print one line starting with "blackboard ready" when serving."""
    reg = registry if registry is not None else default_registry
    for mod in types:
        reg.import_module(mod)
    out = ready_stream if ready_stream is not None else sys.stdout

    async def main() -> None:
        node = BlackboardNode(net, db=db, sync=sync, registry=reg, frames=FrameTree(history=history), dispatch=dispatch,
                              test_hold_after_journal=test_hold_after_journal)
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, node._stop.set)
        dump_stacks_on_request()

        def ready() -> None:
            eps = ",".join(net.listen or net.connect) or "-"
            print(
                f"blackboard ready ns={net.namespace} endpoints={eps} db={db} sync={sync} "
                f"tokens={len(node.store)} types={','.join(reg.names()) or '-'}",
                file=out,
                flush=True,
            )

        gc.collect()
        gc.freeze()  # what was loaded at start is long-lived: keep it out of the collector's scans
        gc.set_threshold(*_GC_THRESHOLDS)
        await node.run(on_ready=ready)

    asyncio.run(main())
