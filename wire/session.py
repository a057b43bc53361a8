"""The one file of Sidewalk that imports zenoh: the process's session and its typed operations.

A process holds ONE Zenoh session per network configuration: `open_session(net)` returns a
`Session` handle on it, opening it the first time and sharing it afterwards (the module runtime, the
blackboard client, the recorder… of one process all use the same one). Each handle owns what it
declared and undeclares it on `close()`; the Zenoh session itself closes with its last handle.
Always close explicitly: an unclosed session hangs interpreter exit, and `atexit` is too late.

Callbacks given here run on Zenoh threads and must never block: hand the work to asyncio with
`loop.call_soon_threadsafe` (the `wire.aio.Link` helpers do exactly that).

Encodings: our processes send msgpack (`application/msgpack`). A payload is JSON when its encoding
says so (`application/json`, `text/json`), or when no encoding was set (a standard Zenoh tool) and
its bytes parse as a JSON object or array; replies go back in the request's format.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
from typing import Any, Callable

import zenoh

from wire.channel_counts import registry as _channels
from wire.errors import ConnectError, SessionClosedError
from wire.network import NetworkConfig
from wire.timemode import lockstep_enabled

__all__ = [
    "Session", "Query", "Reply", "Sample", "Publisher", "open_session", "secure_hint", "session_stats", "traffic", "barrier_traffic", "is_json_payload",
    "gets_in_flight", "key_includes", "lockstep_topology", "own_traffic",
]

_JSON = zenoh.Encoding.APPLICATION_JSON
_MSGPACK = zenoh.Encoding("application/msgpack")
_JSON_PREFIXES = ("application/json", "text/json")
_UNSET = ("", "zenoh/bytes")


def is_json_payload(encoding: str, payload: bytes) -> bool:
    """Return whether `payload` is JSON: its encoding says so, or no encoding was set and it parses as JSON.

    Our own senders always set `application/msgpack`, so sniffing applies only to foreign tools; a
    sniffed payload must be a JSON object or array (a msgpack map or array never parses as one).
    """
    if encoding.startswith(_JSON_PREFIXES):
        return True
    if encoding.split(";", 1)[0] not in _UNSET:
        return False
    head = payload.lstrip()[:1]
    if head not in (b"{", b"["):
        return False
    try:
        json.loads(payload)
    except (ValueError, UnicodeDecodeError):
        return False
    return True


#: The key segment of the lock-step barrier (`wire.keys.LockstepKeys`): its traffic is also counted apart.
_BARRIER_SEGMENT = "/@lockstep/"


class _Traffic:
    """Messages and payload bytes this process sent and received through Zenoh (all sessions).

    The lock-step barrier's asks and answers count here too (the barrier's own counters rely on it), and
    again in `barrier`, so that a report can show the run mode's cost apart from the modules' traffic.
    """

    __slots__ = ("lock", "msgs_out", "bytes_out", "msgs_in", "bytes_in", "barrier")

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.msgs_out = self.bytes_out = self.msgs_in = self.bytes_in = 0
        self.barrier = [0, 0, 0, 0]  # msgs out, bytes out, msgs in, bytes in on the barrier's keys

    def out(self, n: int, key: object = "") -> None:
        with self.lock:
            self.msgs_out += 1
            self.bytes_out += n
            if _BARRIER_SEGMENT in str(key):
                self.barrier[0] += 1
                self.barrier[1] += n

    def into(self, n: int, key: object = "") -> None:
        with self.lock:
            self.msgs_in += 1
            self.bytes_in += n
            if _BARRIER_SEGMENT in str(key):
                self.barrier[2] += 1
                self.barrier[3] += n


_traffic = _Traffic()


class _InFlight:
    """Callback gets this process sent whose end (`on_done`) has not been handed over yet (all sessions)."""

    __slots__ = ("lock", "gets")

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.gets = 0

    def add(self, n: int) -> None:
        with self.lock:
            self.gets += n


_in_flight = _InFlight()


def key_includes(expr: str, key: str) -> bool:
    """Return whether key expression `expr` includes key `key` (a subscription on `expr` receives puts on `key`)."""
    return zenoh.KeyExpr(expr).includes(zenoh.KeyExpr(key))


def gets_in_flight() -> int:
    """Return how many callback gets (`Session.get`) of this process still wait for their end.

    A get counts until its `on_done` callback has returned, so whatever that callback handed to a
    loop is already queued there when the count drops (what the lock-step participant relies on).
    """
    with _in_flight.lock:
        return _in_flight.gets


def traffic() -> tuple[int, int, int, int]:
    """Return (messages out, bytes out, messages in, bytes in) of this process's Zenoh traffic so far (the barrier's included)."""
    t = _traffic
    with t.lock:
        return t.msgs_out, t.bytes_out, t.msgs_in, t.bytes_in


def own_traffic() -> tuple[int, int]:
    """Return (messages out, messages in) of this process's Zenoh traffic without the lock-step barrier's, read at once."""
    t = _traffic
    with t.lock:
        return t.msgs_out - t.barrier[0], t.msgs_in - t.barrier[2]


def barrier_traffic() -> tuple[int, int, int, int]:
    """Return (messages out, bytes out, messages in, bytes in) of this process's traffic on the lock-step barrier's keys."""
    t = _traffic
    with t.lock:
        return tuple(t.barrier)  # type: ignore[return-value]


def _enc(e: Any) -> str:
    return "" if e is None else str(e)


class Query:
    """A received query: key, selector parameters, payload bytes, whether it is JSON; reply, then `finish`."""

    __slots__ = ("_q", "key", "payload", "is_json", "_params", "_own")

    def __init__(self, q: "zenoh.Query", own: str | None = None) -> None:
        self._q = q
        self._own = own
        self.key: str = str(q.key_expr)
        p = q.payload
        self.payload: bytes = p.to_bytes() if p is not None else b""
        _traffic.into(len(self.payload), self.key)
        enc = _enc(q.encoding)
        # a query with neither payload nor encoding comes from a person's tool: answer it in JSON
        self.is_json: bool = is_json_payload(enc, self.payload) if self.payload else (enc.startswith(_JSON_PREFIXES) or enc in _UNSET)
        self._params: dict[str, str] | None = None

    @property
    def parameters(self) -> dict[str, str]:
        """Return the selector parameters (`key?a=1;b=2`) as a dict (malformed ones: none)."""
        if self._params is None:
            try:
                self._params = dict(self._q.parameters)
            except Exception:  # noqa: BLE001 - malformed parameters: treat as none
                self._params = {}
        return self._params

    @property
    def parameters_text(self) -> str:
        """Return the selector parameters as written."""
        return str(self._q.parameters)

    def reply(self, payload: bytes, *, as_json: bool = False, key: str | None = None) -> None:
        """Send a successful reply on `key`, else the queryable's own key (when it has no wildcard), else the query's.

        Replying on the queryable's own key, not on a wildcard query's, lets access control see what is answered.
        """
        _traffic.out(len(payload), self.key)
        self._q.reply(key or self._own or self._q.key_expr, payload, encoding=_JSON if as_json else _MSGPACK)

    def reply_err(self, payload: bytes, *, as_json: bool = False) -> None:
        """Send an error reply."""
        _traffic.out(len(payload), self.key)
        self._q.reply_err(payload, encoding=_JSON if as_json else _MSGPACK)

    def finish(self) -> None:
        """Finalise the query (no more replies; the querier's get ends once every queryable finished)."""
        self._q.drop()


class Reply:
    """One reply to a get: ok flag, replying key (None for errors), payload bytes, whether JSON."""

    __slots__ = ("ok", "key", "payload", "is_json")

    def __init__(self, r: "zenoh.Reply") -> None:
        s = r.ok
        self.ok: bool = s is not None
        if s is None:
            s = r.err
            self.key: str | None = None
        else:
            self.key = str(s.key_expr)
        self.payload: bytes = s.payload.to_bytes()
        self.is_json: bool = _enc(s.encoding).startswith(_JSON_PREFIXES)
        _traffic.into(len(self.payload), self.key or "")


class Sample:
    """A received sample: key, payload bytes, whether it is a delete, whether it is JSON."""

    __slots__ = ("key", "payload", "deleted", "_enc")

    def __init__(self, s: "zenoh.Sample") -> None:
        self.key: str = str(s.key_expr)
        self.payload: bytes = s.payload.to_bytes()
        self.deleted: bool = s.kind == zenoh.SampleKind.DELETE
        _traffic.into(len(self.payload), self.key)
        self._enc = _enc(s.encoding)

    @property
    def is_json(self) -> bool:
        """Return whether the payload is JSON (by encoding, or sniffed when none was set)."""
        return is_json_payload(self._enc, self.payload)


class Publisher:
    """A declared publisher: `put(bytes)`."""

    __slots__ = ("_p", "_key")

    def __init__(self, p: Any, key: str = "") -> None:
        self._p = p
        self._key = key

    def put(self, payload: bytes) -> None:
        """Publish one sample."""
        _traffic.out(len(payload), self._key)
        _channels.put(self._key)
        self._p.put(payload)

    def undeclare(self) -> None:
        """Undeclare the publisher."""
        self._p.undeclare()


class _Shared:
    """The process's Zenoh session for one configuration, with a count of open handles."""

    def __init__(self, net: NetworkConfig, z: "zenoh.Session") -> None:
        self.net = net
        self.z = z
        self.handles = 0


_lock = threading.Lock()
_shared: dict[NetworkConfig, _Shared] = {}
_opened = 0


def session_stats() -> dict[str, int]:
    """Return how many Zenoh sessions this process has opened in all (`opened`) and holds now (`open`)."""
    with _lock:
        return {"opened": _opened, "open": len(_shared)}


_log_started = False


def _start_zenoh_log() -> None:
    """Send Zenoh's own log to stderr when SIDEWALK_ZENOH_LOG names a level or filter (e.g. the router's denials:
    `zenoh::net::routing::interceptor::access_control=debug`)."""
    global _log_started
    level = os.environ.get("SIDEWALK_ZENOH_LOG")
    if level and not _log_started:
        _log_started = True
        zenoh.init_log_from_env_or(level)


def lockstep_topology(net: NetworkConfig) -> NetworkConfig:
    """Return `net` as lock-step opens it: a peer that connects to a router becomes the router's client.

    The barrier (`wire.lockstep`) counts what each process sent and received and steps on once two
    waves of asks find the counts still. Peers link to one another directly, so a message on one link
    and the barrier's next ask on another can pass each other: on a loaded machine a message sat on a
    peer link through two waves, and the module handled it a tick late. Through the router, a message
    and every later ask to the same process travel one link in order, so its count is in before the
    ask is answered.
    """
    if lockstep_enabled() and net.mode == "peer" and net.connect and not net.listen:
        return net.model_copy(update={"mode": "client"})
    return net


def _open_zenoh(net: NetworkConfig) -> "zenoh.Session":
    _start_zenoh_log()
    net = lockstep_topology(net)
    try:
        return zenoh.open(zenoh.Config.from_json5(json.dumps(net.zenoh_json())))
    except Exception as exc:  # zenoh raises ZError for every failure
        where = ", ".join(net.endpoints) or "no endpoint"
        detail = str(exc).split(" at /", 1)[0].rstrip(" .!")  # zenoh appends its source location
        if net.secure is not None:
            raise ConnectError(secure_hint(net, f"could not connect to {where}")) from None
        hint = " (is `sidewalk up router` running there, and are --connect/--ns right?)" if net.mode == "client" else ""
        raise ConnectError(f"cannot open a Zenoh {net.mode} session on {where}: {detail}{hint}") from None


def secure_hint(net: NetworkConfig, what: str) -> str:
    """Return `what` followed by what to check in a secure deployment (a refused TLS or password looks like no router)."""
    sec = net.secure
    assert sec is not None
    return (f"{what} with --secure {sec.dir} as role {sec.role!r}: is the router running there with --secure? "
            f"otherwise check the certificate/password for role {sec.role!r} (a wrong CA, certificate or password "
            "is refused silently and looks like this)")


def open_session(net: NetworkConfig) -> "Session":
    """Return a handle on this process's session for `net`, opening it if none is open yet."""
    global _opened
    with _lock:
        sh = _shared.get(net)
        if sh is None:
            sh = _Shared(net, _open_zenoh(net))
            _shared[net] = sh
            _opened += 1
        sh.handles += 1
    return Session(sh)


class Session:
    """A handle on the process's Zenoh session: typed operations, and what this handle declared."""

    def __init__(self, shared: _Shared) -> None:
        self._sh = shared
        self._z = shared.z
        self.net = shared.net
        self._keep: list[Any] = []
        self._counted: dict[int, Any] = {}  # id(subscriber) → its channel counter (wire.channel_counts)
        self._closed = False

    # ---- identity and connectivity ---------------------------------------------------------

    @property
    def zid(self) -> str:
        """Return the Zenoh id of the process's session."""
        return str(self._z.zid())

    @property
    def closed(self) -> bool:
        """Return whether this handle has been closed."""
        return self._closed

    def connected(self) -> bool:
        """Return whether the session reaches at least one router or peer."""
        info = self._z.info
        return bool(list(info.routers_zid())) or bool(list(info.peers_zid()))

    def routers(self) -> list[str]:
        """Return the Zenoh ids of the routers this session is connected to."""
        return [str(z) for z in self._z.info.routers_zid()]

    def peers(self) -> list[str]:
        """Return the Zenoh ids of the peers this session is connected to."""
        return [str(z) for z in self._z.info.peers_zid()]

    def wait_connected(self, timeout: float | None = None, *, every: float = 5.0, name: str = "",
                       cancelled: Callable[[], bool] | None = None) -> None:
        """Block until the session reaches a router or peer, saying so on stderr every `every` [s] wall.

        A session with nothing to connect to (a router, or a listener without `--connect`) returns at once.
        Raise ConnectError after `timeout` [s] (None: wait for ever) or once `cancelled()` is true.
        """
        if not self.net.connect:
            return
        t0 = last = time.monotonic()
        while not self.connected():
            if cancelled is not None and cancelled():
                raise ConnectError(f"{name or 'session'}: stopped while waiting for {', '.join(self.net.connect)}")
            now = time.monotonic()
            if timeout is not None and now - t0 >= timeout:
                if self.net.secure is not None:
                    raise ConnectError(secure_hint(self.net, f"{name or 'session'}: could not connect to "
                                                             f"{', '.join(self.net.connect)} within {timeout:.0f} s"))
                raise ConnectError(
                    f"{name or 'session'}: nothing reachable at {', '.join(self.net.connect)} after {timeout:.0f} s "
                    "(is `sidewalk up router` running there? with --secure, a wrong password or certificate also looks like this)"
                )
            if now - last >= every:
                last = now
                print(f"{name or 'sidewalk'}: waiting for {', '.join(self.net.connect)} — nothing reachable yet, retrying",
                      file=sys.stderr, flush=True)
            time.sleep(0.02)

    # ---- declarations (callbacks run on Zenoh threads) -------------------------------------

    def _check(self) -> None:
        if self._closed:
            raise SessionClosedError("the session handle is closed")

    def queryable(self, key: str, on_query: Callable[[Query], None], *, complete: bool = True) -> Any:
        """Serve queries on `key`; `on_query(Query)` runs on a Zenoh thread and must finish the query."""
        self._check()
        own = None if "*" in key or "$" in key else key
        q = self._z.declare_queryable(key, zenoh.handlers.Callback(lambda q: on_query(Query(q, own)), indirect=False), complete=complete)
        self._keep.append(q)
        return q

    def subscribe(self, key: str, on_sample: Callable[[Sample], None]) -> Any:
        """Subscribe to `key`; `on_sample(Sample)` runs on a Zenoh thread. Return a handle for `undeclare`."""
        self._check()
        counter = _channels.open(key)

        def cb(s: "zenoh.Sample") -> None:
            sample = Sample(s)
            try:
                on_sample(sample)
            finally:  # counted once handed over (see wire.channel_counts)
                _channels.delivered(counter, sample.key)

        return self._counted_sub(self._z.declare_subscriber(key, zenoh.handlers.Callback(cb, indirect=False)), counter)

    def subscribe_payload(self, key: str, on_payload: Callable[[str, bytes], None]) -> Any:
        """Subscribe to `key` where only puts are published; `on_payload(key, bytes)` on a Zenoh thread (hot path)."""
        self._check()
        counter = _channels.open(key)

        def cb(s: "zenoh.Sample") -> None:
            data = s.payload.to_bytes()
            k = str(s.key_expr)
            _traffic.into(len(data), k)
            try:
                on_payload(k, data)
            finally:
                _channels.delivered(counter, k)

        return self._counted_sub(self._z.declare_subscriber(key, zenoh.handlers.Callback(cb, indirect=False)), counter)

    def subscribe_attached(self, key: str, on_payload: Callable[[str, bytes, bytes | None], None]) -> Any:
        """Like `subscribe_payload`, with each sample's attachment (None: none): `on_payload(key, bytes, attachment)` on a Zenoh thread."""
        self._check()
        counter = _channels.open(key)

        def cb(s: "zenoh.Sample") -> None:
            data = s.payload.to_bytes()
            k = str(s.key_expr)
            _traffic.into(len(data), k)
            att = s.attachment
            try:
                on_payload(k, data, None if att is None else att.to_bytes())
            finally:
                _channels.delivered(counter, k)

        return self._counted_sub(self._z.declare_subscriber(key, zenoh.handlers.Callback(cb, indirect=False)), counter)

    def _counted_sub(self, sub: Any, counter: Any) -> Any:
        self._keep.append(sub)
        self._counted[id(sub)] = counter
        return sub

    def publisher(self, key: str, *, droppable: bool = False, as_json: bool = False, express: bool = True) -> Publisher:
        """Declare a reliable publisher on `key`; `droppable` ones drop under congestion instead of blocking.

        `express` samples go out at once, each in its own batch; without it Zenoh batches the samples
        queued while its transmit task was busy.
        """
        self._check()
        pub = self._z.declare_publisher(
            key,
            encoding=_JSON if as_json else _MSGPACK,
            congestion_control=zenoh.CongestionControl.DROP if droppable else zenoh.CongestionControl.BLOCK,
            express=express,
            reliability=zenoh.Reliability.RELIABLE,
        )
        w = Publisher(pub, key)
        self._keep.append(w)
        return w

    def put(self, key: str, payload: bytes, *, as_json: bool = False, droppable: bool = False,
            attachment: bytes | None = None) -> None:
        """Publish one sample (msgpack unless `as_json`), with Zenoh `attachment` bytes beside the payload when given."""
        if self._closed:
            return
        _traffic.out(len(payload), key)
        _channels.put(key)
        self._z.put(
            key, payload, encoding=_JSON if as_json else _MSGPACK,
            congestion_control=zenoh.CongestionControl.DROP if droppable else zenoh.CongestionControl.BLOCK,
            express=True, attachment=attachment,
        )

    def get(
        self,
        selector: str,
        payload: bytes | None = None,
        *,
        as_json: bool = False,
        timeout: float,
        on_reply: Callable[[Reply], None],
        on_done: Callable[[], None],
    ) -> None:
        """Send a query; `on_reply(Reply)` per reply and `on_done()` at the end run on Zenoh threads (timeout wall [s])."""
        self._check()
        _traffic.out(len(payload or b""), selector)

        def done() -> None:
            try:
                on_done()
            finally:
                _in_flight.add(-1)

        _in_flight.add(1)
        try:
            self._z.get(
                selector,
                zenoh.handlers.Callback(lambda r: on_reply(Reply(r)), done, indirect=False),
                payload=payload,
                encoding=_JSON if as_json else _MSGPACK,
                timeout=timeout,
                target=zenoh.QueryTarget.BEST_MATCHING,
                consolidation=zenoh.ConsolidationMode.NONE,
                congestion_control=zenoh.CongestionControl.BLOCK,
                express=True,
            )
        except BaseException:
            _in_flight.add(-1)
            raise

    def get_blocking(self, selector: str, payload: bytes | None = None, *, as_json: bool = False, timeout: float = 5.0) -> list[Reply]:
        """Send a query and wait for every reply (blocking: never call it in a callback or on a loop)."""
        self._check()
        _traffic.out(len(payload or b""), selector)
        replies = self._z.get(
            selector, payload=payload, encoding=_JSON if as_json else _MSGPACK, timeout=timeout,
            target=zenoh.QueryTarget.BEST_MATCHING, consolidation=zenoh.ConsolidationMode.NONE,
        )
        return [Reply(r) for r in replies]

    def liveliness_token(self, key: str) -> Any:
        """Declare a liveliness token on `key` (held until undeclared or closed)."""
        self._check()
        tok = self._z.liveliness().declare_token(key)
        self._keep.append(tok)
        return tok

    def liveliness_subscribe(self, key: str, on_change: Callable[[str, bool], None], *, history: bool = False) -> Any:
        """Watch liveliness tokens under `key`; `on_change(key, alive)` runs on a Zenoh thread (current ones too if `history`)."""
        self._check()
        sub = self._z.liveliness().declare_subscriber(
            key,
            zenoh.handlers.Callback(lambda s: on_change(str(s.key_expr), s.kind == zenoh.SampleKind.PUT), indirect=False),
            history=history,
        )
        self._keep.append(sub)
        return sub

    def liveliness_get(self, key: str, timeout: float) -> list[str]:
        """Return the keys of the live tokens under `key` (blocking up to `timeout` wall [s])."""
        self._check()
        return sorted(str(r.ok.key_expr) for r in self._z.liveliness().get(key, timeout=timeout) if r.ok is not None)

    def admin_get(self, selector: str, timeout: float = 2.0) -> list[tuple[str, Any]]:
        """Query Zenoh's admin space (`@/…`) and return (key, decoded JSON) pairs (blocking)."""
        out = []
        for r in self._z.get(selector, timeout=timeout):
            if r.ok is not None:
                try:
                    out.append((str(r.ok.key_expr), json.loads(r.ok.payload.to_bytes())))
                except ValueError:
                    out.append((str(r.ok.key_expr), r.ok.payload.to_bytes()))
        return out

    def undeclare(self, handle: Any) -> None:
        """Undeclare a subscriber, publisher, queryable or token declared through this handle."""
        try:
            self._keep.remove(handle)
        except ValueError:
            pass
        _channels.close(self._counted.pop(id(handle), None))
        try:
            handle.undeclare()
        except Exception:  # noqa: BLE001 - already gone with the session
            pass

    def close(self) -> None:
        """Undeclare everything this handle declared; close the Zenoh session with its last handle (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for h in reversed(self._keep):
            try:
                h.undeclare()
            except Exception:  # noqa: BLE001 - already gone
                pass
        self._keep.clear()
        for counter in self._counted.values():
            _channels.close(counter)
        self._counted.clear()
        last = False
        with _lock:
            self._sh.handles -= 1
            if self._sh.handles <= 0 and _shared.get(self.net) is self._sh:
                del _shared[self.net]
                last = True
        if last:
            self._z.close()

    def close_within(self, timeout: float, name: str = "session") -> bool:
        """Close (as `close`) on a daemon thread; return whether it finished within `timeout` [s] wall.

        A Zenoh close can hang (seen in the router and the simulator at exit); a process that keeps no state may
        then exit without it (`os._exit`: an interpreter exit would wait for the session's threads).
        """
        closer = threading.Thread(target=self.close, name=f"{name}-close", daemon=True)
        closer.start()
        closer.join(timeout)
        return not closer.is_alive()

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
