"""Channel counts: what this process put on each key, and what each of its subscriptions delivered from each key.

The lock-step barrier (`wire.lockstep`) uses them to tell, from one answer per participant, that no message
between participants is still in flight. A *channel* is a (receiving subscription, concrete key) pair: every put on
the key by a participant should be delivered once through every subscription whose expression includes the key.
Each participant reports, when it answers idle, its puts per key and its deliveries per subscription and key,
counted so that a delivery is counted only once the subscription's callback has returned (the sample is handed to
the loop, so a participant that reads its counts and then finds its loop idle has handled everything it counted).

`settle(...)` compares the counts since the last quiet step: on a channel whose deliveries fall short of the puts,
a message is on its way to that receiver (ask it again); when no channel falls short and every participant
answered idle, nothing is in flight and nobody will send anything more (a message received after its receiver
answered would have to be caused by one sent after its sender answered, and the first such send would need a
receipt after its sender's answer that no channel shows; see `wire.lockstep`). A channel with more deliveries than
puts (a put from outside the barrier, a subscription that came late) cannot be judged by counts: the barrier then
falls back to its two equal waves.

Counting is process-wide (all sessions), like `wire.session`'s traffic counters, and never includes the barrier's
own keys. Puts are counted when sent; deletes are not made by this project.
"""

from __future__ import annotations

import itertools
import os
import secrets
import threading
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

__all__ = ["ChannelCounts", "SubCounts", "Registry", "Settled", "settle", "registry"]


@dataclass(frozen=True)
class SubCounts:
    """One subscription: its process-unique `sid`, its key expression, and deliveries per concrete key since it was declared."""

    sid: int
    expr: str
    delivered: Mapping[str, int]


@dataclass(frozen=True)
class ChannelCounts:
    """One process's counts at one instant: its `proc` id, puts per concrete key, and its subscriptions' deliveries."""

    proc: str
    puts: Mapping[str, int] = field(default_factory=dict)
    subs: Sequence[SubCounts] = ()


class _Sub:
    __slots__ = ("sid", "expr", "delivered")

    def __init__(self, sid: int, expr: str) -> None:
        self.sid = sid
        self.expr = expr
        self.delivered: dict[str, int] = {}


class Registry:
    """This process's channel counts (thread-safe: Zenoh threads count, the loop or the barrier reads)."""

    def __init__(self, excluded: str) -> None:
        self._lock = threading.Lock()
        self._excluded = excluded
        self._puts: dict[str, int] = {}
        self._subs: dict[int, _Sub] = {}
        self._ids = itertools.count(1)
        self._pid = -1
        self._proc = ""

    @property
    def proc(self) -> str:
        """Return this process's id among every host's: `<pid>-<random>` (drawn again in a forked child)."""
        if self._pid != os.getpid():
            self._pid = os.getpid()
            self._proc = f"{self._pid}-{secrets.token_hex(4)}"
        return self._proc

    def put(self, key: str) -> None:
        """Count one put on concrete `key` (before it is sent)."""
        if self._excluded in key:
            return
        with self._lock:
            self._puts[key] = self._puts.get(key, 0) + 1

    def open(self, expr: str) -> _Sub | None:
        """Register a subscription on `expr`; return its counter (None: the barrier's own keys, not counted)."""
        if self._excluded in expr:
            return None
        sub = _Sub(next(self._ids), expr)
        with self._lock:
            self._subs[sub.sid] = sub
        return sub

    def close(self, sub: _Sub | None) -> None:
        """Forget a subscription (undeclared)."""
        if sub is not None:
            with self._lock:
                self._subs.pop(sub.sid, None)

    def delivered(self, sub: _Sub | None, key: str) -> None:
        """Count one sample on concrete `key` delivered through `sub` (after its callback returned)."""
        if sub is None:
            return
        with self._lock:
            sub.delivered[key] = sub.delivered.get(key, 0) + 1

    def snapshot(self) -> ChannelCounts:
        """Return the counts now, read at once."""
        with self._lock:
            return ChannelCounts(self.proc, dict(self._puts),
                                 tuple(SubCounts(s.sid, s.expr, dict(s.delivered)) for s in self._subs.values()))


#: The process's registry (the barrier's keys, under `@lockstep`, are not counted).
registry = Registry("/@lockstep/")


@dataclass(frozen=True)
class Settled:
    """`settle`'s verdict: processes (`proc` ids) with a channel short of deliveries, and channels with more deliveries than puts."""

    short: frozenset[str]
    excess: tuple[str, ...]

    @property
    def quiet(self) -> bool:
        """Return whether every channel balances (nothing in flight, nothing unexplained)."""
        return not self.short and not self.excess


def settle(now: Sequence[ChannelCounts], base: Sequence[ChannelCounts], includes: Callable[[str, str], bool]) -> Settled:
    """Compare every process's channels since `base` (the counts when the last step ended quiet) with `now`.

    `now` and `base` hold one entry per process (`proc`); a process missing from `base` counts from zero.
    `includes(expr, key)` says whether a subscription on `expr` receives puts on concrete `key`.
    """
    before = {c.proc: c for c in base}
    sent: dict[str, int] = {}
    for c in now:
        b = before.get(c.proc)
        for k, n in c.puts.items():
            d = n - (b.puts.get(k, 0) if b is not None else 0)
            if d:
                sent[k] = sent.get(k, 0) + d
    short: set[str] = set()
    excess: list[str] = []
    for c in now:
        b = before.get(c.proc)
        base_subs = {s.sid: s.delivered for s in b.subs} if b is not None else {}
        for s in c.subs:
            was = base_subs.get(s.sid, {})
            keys = {k for k in sent if includes(s.expr, k)} | {k for k, n in s.delivered.items() if n != was.get(k, 0)}
            for k in keys:
                got = s.delivered.get(k, 0) - was.get(k, 0)
                want = sent.get(k, 0) if includes(s.expr, k) else 0
                if got < want:
                    short.add(c.proc)
                elif got > want:
                    excess.append(f"process {c.proc} subscription {s.expr!r} got {got} on {k!r}, {want} put")
    return Settled(frozenset(short), tuple(excess))
