"""An EDDIE module's endpoint: its inbox, services and streams, on the one module runtime.

A module process runs `runtime.run_module(name, endpoint(body), net)`: the runtime (`runtime/`)
owns the session, the sim clock, liveliness, heartbeat and lock-step participation, and the
endpoint is plugged into it as a part (`RuntimePart`): it listens on the module's inbox and, in
lock-step, releases what arrived at each clock tick. `async with Module(name, net) as m:` does the
same without a process around it (tests, tools): it opens a runtime of its own. `m.ready()` declares
the liveliness token and prints the READY line a supervisor waits for.

In lock-step (`wire.lockstep`) what a module receives is released once per sim clock tick: the
streams it follows, then its inbox, each grouped by sender (senders in name order, each sender's
messages in the order it sent them). The barrier makes every message of a step arrive before the
next tick, but not in the same order from run to run, nor in the same slices of the module's loop:
two modules' fixes reaching the navigator in one step, or the map manager cycling once on two state
updates instead of twice, would otherwise change what happens next. A message is released at the
first tick later than the sim time it was sent at (an inbox message's envelope stamp; a stream
sample's attachment, which `publish` adds in lock-step): the map manager's trigger sent on tick t
may reach the controller before tick t itself does, or after, from run to run, and is handled at
the next tick either way. The cost is up to one publication period of sim time before a message is
handled.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import struct
import time
from dataclasses import dataclass
from typing import Any, Awaitable, Callable, TextIO, TypeVar

from runtime import ModuleMain, ModuleRuntime, SimClock
from wire.aio import Link, QueryAnswer, QueryRequest
from wire.keys import EddieKeys, ModuleKeys
from wire.lockstep import lockstep_enabled
from wire.network import NetworkConfig, check_chunk

from eddie.errors import BadMessage, LinkError, LinkTimeout, NoSuchModule, ServiceError
from eddie.toolkit.message import (
    Message, decode_body, decode_envelope, encode_body, encode_envelope, error_payload, error_text, open_envelope,
)
from wire.ratelimit import warn_limited

__all__ = ["Module", "Incoming", "ServiceHandler", "ModuleBody", "endpoint"]

log = logging.getLogger(__name__)

#: the lock-step stamp a stream sample carries as its attachment: the sender's sim time [s], float64 little endian
_STAMP = struct.Struct("<d")

T = TypeVar("T", bound=Message)


@dataclass(frozen=True)
class Incoming:
    """A message taken from an inbox or a service: its sender, the sender's sim stamp [s], the typed message."""

    sender: str
    stamp: float | None
    message: Message


#: A service handler: takes the request, returns the reply (or raises an EddieError: an error reply).
ServiceHandler = Callable[[Incoming], Awaitable[Message]]


#: What an EDDIE module provides: an async function of its endpoint; returning ends the module.
ModuleBody = Callable[["Module"], Awaitable[None]]


class Module:
    """The endpoint of EDDIE module `name` on network `net`: a part of the module runtime, or (`async with`) standalone."""

    def __init__(self, name: str, net: NetworkConfig, *, heartbeat_period: float = 1.0, inbox_size: int = 1000,
                 stdout: TextIO | None = None) -> None:
        self.name = check_chunk(name, "module name")
        self.net = net
        self.keys = EddieKeys(net.namespace)
        self.module_keys = ModuleKeys(net.namespace)
        self.heartbeat_period = heartbeat_period
        self.rt: ModuleRuntime | None = None
        self._own_link: Link | None = None
        self._inbox: asyncio.Queue[bytes] = asyncio.Queue(inbox_size)
        self._stdout = stdout
        #: inbox messages dropped because the inbox was full
        self.dropped = 0
        #: lock-step: what arrived and is not yet released, as (0 stream / 1 inbox, sender, arrival, payload,
        #: stream callback or None for the inbox, the sender's sim time at sending [s] or None), released at
        #: the first tick later than its sending, in that order (None: real time)
        self._held: list[tuple[int, str, int, bytes, Callable[[str, bytes], None] | None, float | None]] | None = (
            [] if lockstep_enabled() else None)
        self._arrivals = itertools.count()

    # ---- lifecycle -----------------------------------------------------------------------

    async def start(self, rt: ModuleRuntime) -> None:
        """Plug into runtime `rt` (as a `RuntimePart`): listen on the inbox; in lock-step, release at each tick."""
        self.rt = rt
        rt.link.subscribe(self.keys.inbox(self.name), self._on_inbox)
        if self._held is not None:  # lock-step: each tick releases what was sent before it, on the loop
            rt.on_tick(self._release)

    def health(self) -> dict[str, Any]:
        """Return nothing: an endpoint adds no heartbeat fields."""
        return {}

    async def __aenter__(self) -> "Module":
        link = Link.open(self.net)
        try:
            rt = ModuleRuntime(self.name, self.net, link, heartbeat_period=self.heartbeat_period, stdout=self._stdout)
            rt.start()
            await rt.plug(self)
        except BaseException:
            link.close()
            raise
        self._own_link = link
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    async def close(self) -> None:
        """Standalone: stop the runtime (says `stopping`) and close the link (idempotent); as a part: nothing to close."""
        if self._own_link is None:
            return
        rt, link, self._own_link = self.rt, self._own_link, None
        if rt is not None:
            await rt.close()
        link.close()

    @property
    def link(self) -> Link | None:
        """Return the runtime's Zenoh link (None before the endpoint is started)."""
        return None if self.rt is None else self.rt.link

    @property
    def clock(self) -> SimClock:
        """Return the runtime's sim clock."""
        return self._rt.clock

    @property
    def _rt(self) -> ModuleRuntime:
        if self.rt is None or self.rt.link.closed:
            raise LinkError(f"module {self.name!r}: the link is not open (use `async with Module(...)` or `endpoint`)")
        return self.rt

    async def wait_connected(self, timeout: float | None = None) -> None:
        """Return once the session reaches a router or peer; wire.ConnectError after `timeout` [s]."""
        await self._link.wait_connected(timeout, name=self.name)

    def ready(self) -> None:
        """Declare the module ready: liveliness token, a ready heartbeat, and `SIDEWALK-READY <name>` on stdout."""
        self._rt.ready()

    @property
    def _link(self) -> Link:
        return self._rt.link

    def now(self) -> float | None:
        """Return the sim time [s], or None before the simulator's first clock tick."""
        return self._rt.now()

    # ---- point-to-point ------------------------------------------------------------------

    async def send(self, dest: str, msg: Message) -> None:
        """Put `msg` into module `dest`'s inbox (fire and forget)."""
        self._link.put(self.keys.inbox(dest), encode_envelope(self.name, msg, self.now()))

    async def receive(self, timeout: float | None = None) -> Incoming:
        """Return the next message of the inbox (EDDIE's blocking read; `timeout` wall [s]).

        Raise LinkTimeout when nothing arrives in time, BadMessage (naming sender and field) for a payload
        that is not a valid message: catch it and receive again, the inbox is intact.
        """
        try:
            raw = await asyncio.wait_for(self._inbox.get(), timeout)
        except asyncio.TimeoutError:
            raise LinkTimeout(f"module {self.name!r}: no message in its inbox within {timeout:g} s") from None
        env, msg = decode_envelope(raw, where=f"{self.name}'s inbox")
        return Incoming(sender=env.sender, stamp=env.stamp, message=msg)

    def pending(self) -> int:
        """Return the number of messages waiting in the inbox."""
        return self._inbox.qsize()

    async def request(self, dest: str, service: str, msg: Message, *, timeout: float = 2.0,
                      reply_type: type[T] | None = None) -> T:
        """Ask module `dest`'s `service` with `msg`; return the typed reply (timeout wall [s]).

        Raise LinkTimeout / NoSuchModule naming dest and service, ServiceError for an error reply,
        BadMessage for a reply that does not decode (or is not a `reply_type`).
        """
        key = self.keys.service(dest, service)
        t0 = time.monotonic()
        replies = await self._link.get(key, encode_envelope(self.name, msg, self.now()), timeout=timeout)
        if not replies:
            if time.monotonic() - t0 >= timeout * 0.95:
                raise LinkTimeout(f"request {dest}/{service}: no reply within {timeout:g} s")
            raise NoSuchModule(f"request {dest}/{service}: no module answers {key}")
        r = replies[0]
        if not r.ok and r.payload == b"Timeout" and time.monotonic() - t0 >= timeout * 0.95:  # Zenoh's own time-out reply
            raise LinkTimeout(f"request {dest}/{service}: no reply within {timeout:g} s")
        if not r.ok:
            raise ServiceError(f"request {dest}/{service}: {error_text(r.payload)}")
        _env, reply = decode_envelope(r.payload, where=f"{self.name} (reply of {dest}/{service})")
        if reply_type is not None and not isinstance(reply, reply_type):
            raise BadMessage(f"reply of {dest}/{service}: expected {reply_type.__name__}, got {type(reply).__name__}",
                             sender=dest, field="type")
        return reply  # type: ignore[return-value]

    def serve(self, service: str, handler: ServiceHandler) -> Any:
        """Answer requests on this module's `service` with `await handler(incoming)` (errors become error replies)."""
        where = f"{self.name}/{service}"

        async def answer(req: QueryRequest) -> QueryAnswer:
            try:
                env, msg = decode_envelope(req.payload, where=where)
                reply = await handler(Incoming(sender=env.sender, stamp=env.stamp, message=msg))
            except BadMessage as exc:
                warn_limited(log, f"bad-message:{where}", "%s: %.200s", where, exc)
                return QueryAnswer(ok=False, payload=error_payload("bad_message", str(exc)), as_json=True)
            except Exception as exc:  # noqa: BLE001 - an error reply, never a crashed module
                from eddie.errors import EddieError

                if not isinstance(exc, EddieError):
                    log.exception("%s: handler failed", where)
                return QueryAnswer(ok=False, payload=error_payload(type(exc).__name__, str(exc)), as_json=True)
            return QueryAnswer(ok=True, payload=encode_envelope(self.name, reply, self.now()))

        return self._link.queryable(self.keys.service(self.name, service), answer)

    # ---- streams -------------------------------------------------------------------------

    def publish(self, stream: str, msg: Message, *, stamp: float | None = None) -> None:
        """Push `msg` (bare fields, msgpack) on this module's stream `stream` to every subscriber.

        In lock-step the sample carries the sim time it belongs to as its Zenoh attachment (a float64,
        little endian): this module's clock, or `stamp` [s sim] when later (a message made from an input
        newer than the clock tick heard, as the controller's state from the simulator's odometry), so a
        receiver releases it at the tick after that time.
        """
        at = None
        if self._held is not None:
            now = self.now()
            at = stamp if now is None else (now if stamp is None else max(now, stamp))
        self._link.put(self.keys.topic(self.name, stream), encode_body(msg),
                       attachment=None if at is None else _STAMP.pack(at))

    def subscribe(self, module: str, stream: str, model: type[T], on_message: Callable[[T], None]) -> Any:
        """Call `on_message(msg)` on the loop for every message of `module`'s `stream`; bad samples are logged, skipped."""
        def on_sample(_key: str, payload: bytes) -> None:
            try:
                msg = decode_body(model, payload, sender=module)
            except BadMessage as exc:
                warn_limited(log, f"bad-stream:{module}/{stream}", "%s: stream %s/%s: %.200s", self.name, module, stream, exc)
                return
            on_message(msg)  # type: ignore[arg-type]

        if self._held is None:
            return self._link.subscribe(self.keys.topic(module, stream), on_sample)
        where = f"{module}/{stream}"

        def held(key: str, payload: bytes, att: bytes | None) -> None:
            assert self._held is not None
            stamp = _STAMP.unpack(att)[0] if att is not None and len(att) == _STAMP.size else None
            self._held.append((0, where, next(self._arrivals), payload, on_sample, stamp))

        return self._link.subscribe_attached(self.keys.topic(module, stream), held)

    # ---- internals -----------------------------------------------------------------------

    def _on_inbox(self, _key: str, payload: bytes) -> None:
        if self._held is not None:
            try:
                env = open_envelope(payload, where=f"{self.name}'s inbox")
                sender, stamp = env.sender, env.stamp
            except BadMessage:
                sender, stamp = "", None  # `receive()` reports it, in its turn
            self._held.append((1, sender, next(self._arrivals), payload, None, stamp))
            return
        self._put(payload)

    def _put(self, payload: bytes) -> None:
        try:
            self._inbox.put_nowait(payload)
        except asyncio.QueueFull:
            self.dropped += 1
            warn_limited(log, "inbox-full", "%s: inbox full, message dropped (%d so far)", self.name, self.dropped)

    def _release(self) -> None:
        """Lock-step: hand over what was sent before the tick just taken (runs on the loop, after the clock advanced)."""
        if self._held:
            # only what was sent before this tick: a message sent in this tick may reach this module before or
            # after the tick itself does, so it waits for the next one either way
            if self.rt is None:
                return
            t = self.rt.clock.now()  # not `self.clock`: a tick queued before the link closed may run after it
            due, wait = [], []
            for h in self._held:
                (due if h[5] is None or h[5] < t else wait).append(h)
            if not due:
                return
            self._held = wait
            for _kind, where, _arrival, raw, on_sample, _stamp in sorted(due, key=lambda h: h[:3]):
                if on_sample is None:
                    self._put(raw)
                else:
                    on_sample(where, raw)


def endpoint(body: ModuleBody) -> ModuleMain:
    """Return the runtime main that runs `body` on the module's EDDIE endpoint (`run_module(name, endpoint(body), net)`)."""

    async def main(rt: ModuleRuntime) -> None:
        m = Module(rt.name, rt.net)
        await rt.plug(m)
        await body(m)

    return main
