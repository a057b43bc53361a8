"""Lock-step: the simulator steps on only once every process has handled what it received.

Two sides, over the process's one Zenoh session:

- a **participant** (`Participant`) in every process whose behaviour depends on sim time (each
  CODGER module through `ModuleRuntime`, the blackboard node, each EDDIE module) subscribes to the
  barrier's ask (`sidewalk/<ns>/@lockstep/ask`, one put per wave for every participant), answers on
  `@lockstep/report/<name>` and declares the liveliness token `@lockstep/alive/<name>` (`<name>` =
  module name and pid, so a restarted module is a new participant). Asked, it answers on its asyncio
  loop only once that loop is quiescent: no callback ready to run, no job of the loop's default
  executor in flight (`asyncio.to_thread`, e.g. EDDIE's planning worker), no get of the process
  still waiting for its replies (`wire.session.gets_in_flight`, e.g. a capture the simulator still
  renders), and every busy probe the process added false (the blackboard node's inline dispatch, a
  blackboard client's unacknowledged writes). Its answer (`ParticipantReport`) carries the process's
  Zenoh message counters, received and sent, without the barrier's own traffic. A participant still
  busy after `busy_reply_s` [s wall] answers `busy=True` instead — from a keeper thread when the loop
  itself cannot run (a long synchronous computation, a process starved of CPU) — so the barrier can
  tell a long job or a loaded machine (it waits) from a stopped process (silent: it skips it).
- the **barrier** (`Barrier`), in the simulator node: after each clock publication it asks every
  participant in waves (each wave one put, its answers matched by the wave's sequence number) until
  two waves in a row find everyone known by liveliness idle with the same counters, the simulator's
  own included (a message sent but not yet received changes a receiver's counter between the waves,
  so the barrier waits for it). One wave is enough when everyone answers idle and **no participant
  sent anything since the last step that ended quiet**: then the only messages that can be in flight
  are the simulator's own, and those travel each link ahead of the ask (below), so nothing is.
  Since session 34 the answers also carry the process's **channel counts** (`wire.channel_counts`: puts
  per key, deliveries per subscription and key, read before the loop is found idle): when the last
  step ended quiet, one wave in which everyone is idle and no channel is short of deliveries is quiet
  (a message received after its receiver answered would need a send after its sender answered, and the
  first such send a receipt no channel shows); a channel short of deliveries gets its receiver asked
  again alone (an ask naming them: the others drop it on their Zenoh thread), not everyone; counts that cannot decide (a delivery nobody
  counted as put: a put from outside the barrier, a subscription declared late) fall back to the
  waves of counters above. A
  participant whose token went is dropped at once (a killed process); one that does not answer
  within `timeout_s` [s wall] (SIGSTOPped, a wedged loop) becomes *silent*: skipped for the rest of
  that step and not waited for in later steps either, only heard (every ask reaches it) until it
  answers idle again, so a module wedged for 5 s sim stays away 5 s sim, as it would in real time,
  at lock-step speed rather than one time-out per step. One that stays busy for `busy_limit_s`
  [s wall] is skipped and then treated as silent. Both are counted (`BarrierStats.skips`,
  `.silenced`), so faults never hang a run.

Counters cannot see a put still in flight across two whole waves (its sender counted it in both, its
receiver in neither). Between peers linked directly that happened on a loaded machine (a put on one
peer link, the asks on others), so in lock-step every process that connects to a router is its
client (`wire.session.lockstep_topology`): a put and every later ask to its receiver then travel
the router's one link to that process, in order (same priority, reliable), and the receiver has
counted the put before it answers. What still links directly (a process others connect to) keeps
the hazard; gets are exact (counted until their end).

Why puts and not one get per participant: a get costs a query, a reply and a final message through
the router for each participant and wave; a broadcast ask costs one put in and one out per
participant. The keys sit under a verbatim chunk (`@lockstep`) so that no `**` subscriber (the
recorder, the monitor) receives them. The barrier is most of a lock-step run's CPU (`sidewalk bench lockstep`).

Processes take part when `SIDEWALK_LOCKSTEP=1` is in their environment (`lockstep_enabled()`;
`sidewalk run --lockstep` sets it for every child, with PYTHONHASHSEED fixed); the same variable
switches their wall-clock decisions to counts (e.g. the planners' wall-time caps). Without it
nothing here is created and real-time behaviour is unchanged.

Zenoh rules: callbacks only hand over (`call_soon_threadsafe`, an Event); answers are sent from the
loop (participant) or collected by callbacks (barrier); every declaration is undeclared by `close()`.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import os
import threading
import time
from typing import Any, Callable

import msgpack
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from wire.channel_counts import ChannelCounts, SubCounts, registry as channel_registry, settle
from wire.errors import PayloadError, WireError
from wire.keys import LockstepKeys
from wire.session import Session, gets_in_flight, key_includes, own_traffic
from wire.timemode import LOCKSTEP_ENV, lockstep_enabled, lockstep_env

__all__ = [
    "LOCKSTEP_ENV", "lockstep_enabled", "lockstep_env", "LockstepError", "LockstepPayloadError", "NotReleasedError",
    "BarrierAsk", "ChannelReport", "ParticipantReport", "BarrierResult", "BarrierStats", "LockstepRelease",
    "Participant", "Barrier", "participant_name", "encode", "decode",
]

log = logging.getLogger(__name__)

def participant_name(name: str, pid: int | None = None) -> str:
    """Return the participant name of process `pid` (default: this one) running `name`: `<name>-<pid>`."""
    return f"{name}-{os.getpid() if pid is None else pid}"


class LockstepError(WireError):
    """Root of the lock-step errors."""

    code = "lockstep"


class LockstepPayloadError(LockstepError, PayloadError):
    """A barrier payload that does not decode (the message says which and why)."""

    code = "bad_request"


class NotReleasedError(LockstepError):
    """Nothing answered a release: no lock-step simulator runs in the namespace (the message names the key)."""

    code = "not_released"


_FROZEN = ConfigDict(frozen=True, extra="forbid")


class BarrierAsk(BaseModel):
    """What the barrier asks: its sequence number, the step it waits for, the wave, and the sim time [s sim] just published."""

    model_config = _FROZEN

    seq: int = Field(ge=0)
    step: int = Field(ge=0)
    wave: int = Field(ge=0)
    sim_time: float
    #: the participants asked (empty: everyone); the others drop the ask unanswered
    only: tuple[str, ...] = ()


class ChannelReport(BaseModel):
    """A process's channel counts (`wire.channel_counts`): its id, its puts per key, each subscription's deliveries per key."""

    model_config = _FROZEN

    proc: str
    puts: dict[str, int] = {}
    #: (subscription id, key expression, deliveries per concrete key)
    subs: tuple[tuple[int, str, dict[str, int]], ...] = ()

    @classmethod
    def of(cls, c: ChannelCounts) -> "ChannelReport":
        """Return the wire form of counts `c`."""
        return cls(proc=c.proc, puts=dict(c.puts), subs=tuple((s.sid, s.expr, dict(s.delivered)) for s in c.subs))

    def counts(self) -> ChannelCounts:
        """Return the counts this report carries."""
        return ChannelCounts(self.proc, self.puts, tuple(SubCounts(sid, expr, d) for sid, expr, d in self.subs))


class ParticipantReport(BaseModel):
    """A participant's answer: idle or still busy, and its Zenoh counters without the barrier's traffic.

    `received`/`sent` count messages (samples, queries, replies) since the process started;
    `waited_s` [s wall] is how long it held the answer back while busy; `seq` is the ask's; `channels` are the
    process's channel counts, read before it found its loop idle (None in a busy answer).
    """

    model_config = _FROZEN

    name: str
    seq: int
    step: int
    wave: int
    busy: bool
    received: int = Field(ge=0)
    sent: int = Field(ge=0)
    waited_s: float = Field(ge=0.0)
    channels: ChannelReport | None = None


class BarrierResult(BaseModel):
    """One barrier: the step, its waves, who answered, who was skipped (silent or busy too long), its wall time [s wall]."""

    model_config = _FROZEN

    step: int
    waves: int
    participants: tuple[str, ...]
    skipped: tuple[str, ...] = ()
    #: silent since an earlier step (no answer within the time-out): probed, not waited for
    silent: tuple[str, ...] = ()
    wall_s: float = Field(ge=0.0)


class BarrierStats(BaseModel):
    """What the barrier did so far: steps (`one_wave` of them quiet after one wave), waves, skips, participants gone silent / heard again, dropped, wall time [s wall]."""

    model_config = ConfigDict(extra="forbid")

    steps: int = 0
    one_wave: int = 0
    #: steps found quiet by their channel counts (`wire.channel_counts`), and waves that asked only some participants
    by_channels: int = 0
    targeted_waves: int = 0
    #: steps whose channel counts could not decide (a put from outside the barrier, a late subscription): two equal waves
    channel_fallbacks: int = 0
    waves: int = 0
    skips: int = 0
    silenced: int = 0
    heard_again: int = 0
    joined: int = 0
    dropped: int = 0
    wall_s: float = 0.0
    max_wall_s: float = 0.0


class LockstepRelease(BaseModel):
    """The simulator's answer to a release: the sim time [s sim] it steps on from, and whether it was held."""

    model_config = _FROZEN

    sim_time: float
    was_held: bool


def encode(model: BaseModel) -> bytes:
    """Return a barrier payload as msgpack."""
    return msgpack.packb(model.model_dump(mode="json"), use_bin_type=True)


def decode(cls: type[BaseModel], payload: bytes, *, as_json: bool = False) -> Any:
    """Return a barrier payload of type `cls` (msgpack, or JSON); raise LockstepPayloadError."""
    try:
        if as_json:
            return cls.model_validate_json(payload)
        return cls.model_validate(msgpack.unpackb(payload, raw=False))
    except (ValidationError, ValueError, TypeError, msgpack.UnpackException) as exc:
        raise LockstepPayloadError(f"bad {cls.__name__}: {str(exc)[:300]}") from None


# ---- participant --------------------------------------------------------------------------------

class _CountingExecutor(concurrent.futures.ThreadPoolExecutor):
    """The loop's default executor, counting its jobs in flight until their result reached the loop.

    The future handed to asyncio is a relay, completed by the job's end; only after completing it
    (which queues asyncio's hand-over of the result on the loop) is the count's decrement queued. So
    when the count drops, the hand-over has run and the waiting coroutine's wake-up is ready: the loop
    never looks idle between a job's end and its coroutine's next step. (Decrementing from a done
    callback of the job's own future raced with asyncio's: the loop could run the decrement while the
    worker thread had not yet queued the hand-over, and answer idle with a result on its way — a
    lock-step run that did not repeat under load.)
    """

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        super().__init__(thread_name_prefix="lockstep-worker")
        self._loop = loop
        self.in_flight = 0  # changed on the loop thread only

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> concurrent.futures.Future:
        self.in_flight += 1  # run_in_executor submits from the loop thread
        job = super().submit(fn, *args, **kwargs)
        relay: concurrent.futures.Future = concurrent.futures.Future()
        relay.add_done_callback(lambda r: job.cancel() if r.cancelled() else None)  # asyncio cancelled its wait
        job.add_done_callback(lambda j: self._done(j, relay))
        return relay

    def _done(self, job: concurrent.futures.Future, relay: concurrent.futures.Future) -> None:
        try:
            if not relay.done():
                if job.cancelled():
                    relay.cancel()
                elif (exc := job.exception()) is not None:
                    relay.set_exception(exc)
                else:
                    relay.set_result(job.result())
        except concurrent.futures.InvalidStateError:  # cancelled by asyncio meanwhile
            pass
        finally:
            try:
                self._loop.call_soon_threadsafe(self._dec)
            except RuntimeError:  # loop closed
                pass

    def _dec(self) -> None:
        self.in_flight -= 1


class Participant:
    """This process's side of the barrier: answer asks once the loop is quiescent (see the module docstring).

    Create it on the running loop with the process's `Session`; `add_probe(fn)` adds a busy test
    (`fn()` true = busy; called on the loop thread, must be cheap and never block); `close()`.
    """

    def __init__(self, session: Session, name: str, *, busy_reply_s: float = 0.25, poll_s: float = 0.001) -> None:
        self.name = name
        self._session = session
        self._keys = LockstepKeys(session.net.namespace)
        self._loop = asyncio.get_running_loop()
        self._busy_reply_s = busy_reply_s
        self._poll_s = poll_s
        self._probes: list[Callable[[], bool]] = []
        self._executor = _CountingExecutor(self._loop)
        self._loop.set_default_executor(self._executor)
        self._pending: tuple[BarrierAsk, float, bytes] | None = None
        self._timer: asyncio.Handle | None = None
        self._closed = False
        #: asks answered, and how many of them were answered busy (by the loop or the keeper)
        self.answered = 0
        self.busy_answers = 0
        # the keeper: the newest ask (payload, arrival [s monotonic]) and the last one the loop answered
        self._newest: tuple[bytes, float] | None = None
        self._answered_payload: bytes | None = None
        self._keeper_stop = threading.Event()
        self._pub = session.publisher(self._keys.report(name))
        self._keeper = threading.Thread(target=self._keep_answering, name=f"lockstep-keeper-{name}", daemon=True)
        self._keeper.start()
        self._sub = session.subscribe_payload(self._keys.ask, self._on_ask)
        self._tok = session.liveliness_token(self._keys.alive(name))

    def add_probe(self, busy: Callable[[], bool]) -> None:
        """Add a busy test run on the loop before each answer (true: not quiescent yet)."""
        self._probes.append(busy)

    @property
    def executor_in_flight(self) -> int:
        """Return the jobs of the loop's default executor not yet handed back to the loop."""
        return self._executor.in_flight

    def close(self) -> None:
        """Undeclare the subscription, the publisher and the token (idempotent; the session stays the caller's)."""
        if self._closed:
            return
        self._closed = True
        if self._timer is not None:
            self._timer.cancel()
        self._pending = None
        self._keeper_stop.set()
        for h in (self._tok, self._sub):
            self._session.undeclare(h)
        self._keeper.join(2.0)
        self._session.undeclare(self._pub)

    # ---- Zenoh thread -----------------------------------------------------------------------

    def _on_ask(self, _key: str, payload: bytes) -> None:
        try:  # an ask for others only is dropped here, without waking the loop
            only = msgpack.unpackb(payload, raw=False).get("only")
        except Exception:  # noqa: BLE001 - not an ask: `_take` says so
            only = None
        if only and self.name not in only:
            return
        self._newest = (payload, time.monotonic())
        try:
            self._loop.call_soon_threadsafe(self._take, payload)
        except RuntimeError:  # loop closed
            pass

    # ---- keeper thread ---------------------------------------------------------------------

    def _keep_answering(self) -> None:
        """Answer `busy` for an ask the loop has not answered within `busy_reply_s` [s wall] (checked twice a period).

        A loop held by a long synchronous computation, or a process starved of CPU on a loaded
        machine, cannot run `_check`; without this the barrier would take it for a stopped one
        (silent) and step on without it, and the run would no longer repeat. A SIGSTOPped process
        stops this thread too, so it stays silent, as it should.
        """
        answered_busy: bytes | None = None
        while not self._keeper_stop.wait(self._busy_reply_s / 2):
            newest = self._newest
            if newest is None or newest[0] is self._answered_payload or newest[0] is answered_busy:
                continue
            payload, t0 = newest
            waited = time.monotonic() - t0
            if waited < self._busy_reply_s:
                continue
            answered_busy = payload
            try:
                ask = decode(BarrierAsk, payload)
            except LockstepPayloadError:
                continue
            sent, received = own_traffic()
            self.busy_answers += 1
            self._pub.put(encode(ParticipantReport(name=self.name, seq=ask.seq, step=ask.step, wave=ask.wave, busy=True,
                                                   received=received, sent=sent, waited_s=waited)))

    # ---- loop thread -----------------------------------------------------------------------

    def _take(self, payload: bytes) -> None:
        try:
            ask = decode(BarrierAsk, payload)
        except LockstepPayloadError as exc:
            log.warning("lockstep: ignoring an ask: %s", exc)
            return
        if self._closed:
            return
        # only the newest ask is answered (the barrier moved on from older ones)
        self._pending = (ask, time.monotonic(), payload)
        if self._timer is None:
            self._check()

    def _busy(self) -> bool:
        ready = getattr(self._loop, "_ready", None)  # asyncio's queue of callbacks ready to run
        if ready:
            return True
        if self._executor.in_flight or gets_in_flight():
            return True
        return any(p() for p in self._probes)

    def _check(self) -> None:
        self._timer = None
        if self._pending is None or self._closed:
            return
        ask, t0, payload = self._pending
        waited = time.monotonic() - t0
        # the counts first, then the loop: whatever they counted was handed to the loop before, so it shows as busy
        sent, received = own_traffic()
        channels = channel_registry.snapshot()
        busy = self._busy()
        if busy and waited < self._busy_reply_s:
            if getattr(self._loop, "_ready", None):
                self._timer = self._loop.call_soon(self._check)  # after what is ready now: real work, not a spin
            else:
                self._timer = self._loop.call_later(self._poll_s, self._check)
            return
        self._pending = None
        rep = ParticipantReport(name=self.name, seq=ask.seq, step=ask.step, wave=ask.wave, busy=busy,
                                received=received, sent=sent, waited_s=waited,
                                channels=None if busy else ChannelReport.of(channels))
        self._answered_payload = payload
        self.answered += 1
        self.busy_answers += int(busy)
        self._pub.put(encode(rep))


# ---- barrier ------------------------------------------------------------------------------------

class _Wave:
    """The answers to one ask, collected on Zenoh threads (under the barrier's lock)."""

    def __init__(self, seq: int, names: list[str]) -> None:
        self.seq = seq
        self.expect = set(names)
        self.done = threading.Event()
        self.reports: dict[str, ParticipantReport] = {}
        if not names:
            self.done.set()


#: Waves that ask only the participants short of a delivery (with nobody busy), before everyone is asked again.
TARGETED_WAVES = 4


class Barrier:
    """The simulator's side: `wait(step, sim_time)` returns once every live participant handled its inputs.

    `timeout_s` [s wall]: how long an ask may go unanswered before its participant is skipped for
    the step; `busy_limit_s` [s wall]: how long a participant may answer busy in one step before it is
    skipped; `quiet_waves`: consecutive waves with the same idle counters that make a step quiet (≥ 2)
    when someone sent something since the last quiet step (else one wave is enough).
    """

    def __init__(self, session: Session, *, timeout_s: float = 2.0, busy_limit_s: float = 60.0, quiet_waves: int = 2) -> None:
        if quiet_waves < 2:
            raise ValueError("quiet_waves must be ≥ 2 (one wave alone cannot see a message in flight)")
        self._session = session
        self._keys = LockstepKeys(session.net.namespace)
        self.timeout_s = timeout_s
        self.busy_limit_s = busy_limit_s
        self.quiet_waves = quiet_waves
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        self._members: set[str] = set()
        self.stats = BarrierStats()
        self._silent: set[str] = set()
        self._wave_now: _Wave | None = None  # under _lock
        self._seq = 0
        #: participant → messages sent when the last step ended quiet (None: that step was not quiet)
        self._baseline: dict[str, int] | None = None
        #: every process's channel counts when the last step ended quiet, with its participants (None: not quiet)
        self._channel_base: tuple[frozenset[str], tuple[ChannelCounts, ...]] | None = None
        self._includes: dict[tuple[str, str], bool] = {}
        self._closed = False
        self._pub = session.publisher(self._keys.ask)
        self._reports = session.subscribe_payload(self._keys.report_all, self._on_report)
        self._sub = session.liveliness_subscribe(self._keys.alive_all, self._on_alive, history=True)

    def members(self) -> list[str]:
        """Return the participants alive now, sorted."""
        with self._lock:
            return sorted(self._members)

    def wait_members(self, until: Callable[[set[str]], bool], timeout: float) -> bool:
        """Block until `until(members)` holds (True) or `timeout` [s wall] passed (False)."""
        with self._changed:
            return self._changed.wait_for(lambda: until(set(self._members)), timeout)

    def close(self) -> None:
        """Stop following liveliness and answers (idempotent; the session stays the caller's)."""
        if not self._closed:
            self._closed = True
            for h in (self._sub, self._reports, self._pub):
                self._session.undeclare(h)

    def _on_alive(self, key: str, alive: bool) -> None:  # Zenoh thread: a set update under a lock
        name = key.rsplit("/", 1)[-1]
        with self._lock:
            if alive and name not in self._members:
                self._members.add(name)
                self.stats.joined += 1
            elif not alive and name in self._members:
                self._members.discard(name)
                self._silent.discard(name)
                self.stats.dropped += 1
                log.info("lockstep: %s is gone (dropped)", name)
            self._changed.notify_all()

    def _on_report(self, key: str, payload: bytes) -> None:  # Zenoh thread
        try:
            rep = decode(ParticipantReport, payload)
        except LockstepPayloadError as exc:
            log.warning("lockstep: a bad answer on %s: %s", key, exc)
            return
        with self._lock:
            if rep.name in self._silent and not rep.busy:
                self._silent.discard(rep.name)
                self.stats.heard_again += 1
                log.info("lockstep: %s answers again: waited for from the next step", rep.name)
                self._changed.notify_all()
            w = self._wave_now
            if w is not None and rep.seq == w.seq and rep.name in w.expect:
                w.reports[rep.name] = rep
                if len(w.reports) == len(w.expect):
                    w.done.set()

    def silent(self) -> list[str]:
        """Return the participants not waited for (no answer within the time-out since), sorted."""
        with self._lock:
            return sorted(self._silent)

    def wait_heard(self, name: str, timeout: float) -> bool:
        """Block until `name` is not silent (True) or `timeout` [s wall] passed (False)."""
        with self._changed:
            return self._changed.wait_for(lambda: name not in self._silent, timeout)

    def _skip(self, name: str, skipped: set[str]) -> None:
        """Skip `name` for the rest of this step and make it silent: not waited for until it answers idle."""
        skipped.add(name)
        self.stats.skips += 1
        with self._lock:
            if name in self._members and name not in self._silent:
                self._silent.add(name)
                self.stats.silenced += 1

    def _wave(self, names: list[str], step: int, wave: int, sim_time: float, *, only: bool = False) -> _Wave:
        """Ask `names` (one broadcast put; with `only`, the others drop it unanswered) and collect their answers."""
        with self._lock:
            self._seq += 1
            w = self._wave_now = _Wave(self._seq, names)
        self._pub.put(encode(BarrierAsk(seq=w.seq, step=step, wave=wave, sim_time=sim_time, only=tuple(names) if only else ())))
        w.done.wait(self.timeout_s)
        with self._lock:
            self._wave_now = None
        return w

    def _key_includes(self, expr: str, key: str) -> bool:
        hit = self._includes.get((expr, key))
        if hit is None:
            try:
                hit = key_includes(expr, key)
            except Exception:  # noqa: BLE001 - not a key expression: no channel (an excess falls back to two waves)
                hit = False
            self._includes[(expr, key)] = hit
        return hit

    @staticmethod
    def _processes(latest: dict[str, ParticipantReport], own: ChannelCounts) -> tuple[tuple[ChannelCounts, ...], dict[str, list[str]]]:
        """Return one set of channel counts per process (this one's `own`) and the participants of each."""
        by_proc: dict[str, ChannelCounts] = {own.proc: own}
        names: dict[str, list[str]] = {}
        for n, r in latest.items():
            assert r.channels is not None
            c = r.channels.counts()
            names.setdefault(c.proc, []).append(n)
            if c.proc == own.proc:
                continue
            have = by_proc.get(c.proc)
            if have is not None:  # two participants of one process: the newer counts (each is cumulative)
                subs = {x.sid: x for x in have.subs}
                for x in c.subs:
                    old = subs.get(x.sid)
                    subs[x.sid] = x if old is None else SubCounts(x.sid, x.expr, {k: max(v, old.delivered.get(k, 0)) for k, v in
                                                                                  {**old.delivered, **x.delivered}.items()})
                c = ChannelCounts(c.proc, {k: max(c.puts.get(k, 0), have.puts.get(k, 0)) for k in {*c.puts, *have.puts}},
                                  tuple(subs.values()))
            by_proc[c.proc] = c
        return tuple(by_proc.values()), names

    def wait(self, step: int, sim_time: float, *, stop: threading.Event | None = None) -> BarrierResult:
        """Return once every participant is idle and nothing between them is in flight.

        The first wave asks everyone. When the last step ended quiet, the answers' channel counts
        (`wire.channel_counts`) decide: every participant idle and no channel short of deliveries is
        quiet after that one wave; otherwise the next wave asks only the participants still busy or
        short of a delivery (the ask names them). When the counts cannot decide (a delivery without a
        put, no quiet step before, a participant skipped) or have not settled after `TARGETED_WAVES`
        such waves, every participant is asked until `quiet_waves` waves in a row find everyone idle
        with the same counters (or one wave, when none of them sent anything since the last quiet step).

        `step` is the simulator's step count, `sim_time` [s sim] the time just published; `stop` (set)
        ends the wait at once.
        """
        t0 = time.monotonic()
        skipped: set[str] = set()
        busy_since: dict[str, float] = {}
        prev: tuple | None = None
        same = 1
        waves = 0
        quiet = False
        answered: tuple[str, ...] = ()
        reports: dict[str, ParticipantReport] = {}
        latest: dict[str, ParticipantReport] = {}  # each participant's newest answer in this step
        base = self._channel_base
        by_channels = base is not None
        only: list[str] | None = None  # the participants the next wave asks alone (None: everyone)
        targeted = 0
        settled: tuple[ChannelCounts, ...] | None = None  # the counts a quiet verdict by channels was drawn from
        while not self._closed and not (stop is not None and stop.is_set()):
            if only is None:
                silent = set(self.silent())
                names = [n for n in self.members() if n not in skipped and n not in silent]
            else:
                names = only
            was_only = only is not None
            w = self._wave(names, step, waves, sim_time, only=was_only)
            waves += 1
            now = time.monotonic()
            alive = set(self.members())
            all_idle = True
            for n in names:
                rep = w.reports.get(n)
                if rep is None:
                    if n in alive:  # silent (stopped, wedged): not waited for until it answers; gone: dropped by liveliness
                        self._skip(n, skipped)
                        log.warning("lockstep: %s did not answer within %.1f s at step %d: not waited for until it answers",
                                    n, self.timeout_s, step)
                    all_idle = False
                elif rep.busy:
                    all_idle = False
                    first = busy_since.setdefault(n, now - rep.waited_s)
                    if now - first >= self.busy_limit_s:  # a loop that never ends: not waited for until it answers idle
                        self._skip(n, skipped)
                        log.warning("lockstep: %s busy for %.1f s: skipped at step %d, not waited for until it answers idle",
                                    n, now - first, step)
            # a wave asking only some that changed nothing for them: what they wait for is not coming soon (a dropped sample)
            stuck = was_only and all(n in latest and not latest[n].busy and not r.busy and r.channels == latest[n].channels
                                     for n, r in w.reports.items())
            latest.update(w.reports)
            if by_channels:
                assert base is not None
                own = channel_registry.snapshot()  # after every answer came in: what they sent here has arrived
                members = set(self.members())
                if skipped or set(latest) != members or set(latest) != base[0] or stuck:
                    by_channels = False  # someone silent, new or gone: the counts cannot speak for everyone
                else:
                    busy = {n for n, r in latest.items() if r.busy or r.channels is None}
                    verdict = None
                    if not busy:
                        procs, proc_names = self._processes(latest, own)
                        verdict = settle(procs, base[1], self._key_includes)
                    if verdict is not None and verdict.excess and not verdict.short:
                        # a delivery with no put counted and nobody short: a put from outside the barrier, or a
                        # subscription declared late (with someone short, it is a send that came after its
                        # sender's answer, caused by a receipt it had not counted: asking the short ones settles it)
                        by_channels = False
                        log.debug("lockstep: step %d not decided by channel counts: %s", step, "; ".join(verdict.excess[:3]))
                    elif verdict is not None and verdict.quiet:
                        quiet = True
                        settled = procs
                        self.stats.by_channels += 1
                        answered = tuple(sorted(latest))
                        reports = latest
                        break
                    elif targeted < TARGETED_WAVES:
                        short = set() if verdict is None else {n for p in verdict.short for n in proc_names.get(p, [])}
                        if verdict is not None and own.proc in verdict.short and not short:
                            by_channels = False  # a put to this process still on its way: counters decide
                        else:
                            only = sorted(busy | short)
                            targeted += verdict is not None  # waiting for a busy one is not undecided: it has no limit here
                            self.stats.targeted_waves += 1
                            continue
                    else:
                        by_channels = False
                if not by_channels:  # from here on, everyone, as before
                    self.stats.channel_fallbacks += 1
                    only = None
                    if was_only:
                        prev, same = None, 0
                        continue
            reports = w.reports
            answered = tuple(sorted(reports))
            if (waves == 1 and all_idle and self._baseline is not None and set(answered) == set(self._baseline)
                    and all(reports[n].sent == self._baseline[n] for n in answered)):
                quiet = True
                self.stats.one_wave += 1
                break
            counters = (tuple((n, reports[n].received, reports[n].sent) for n in answered), own_traffic())
            if all_idle and counters == prev:
                same += 1
                if same >= self.quiet_waves:
                    quiet = True
                    break
            else:
                same = 1 if all_idle else 0
            prev = counters if all_idle else None
        silent_now = tuple(n for n in self.silent() if n not in skipped)
        whole = quiet and not skipped and not silent_now and set(answered) == set(self.members())
        self._baseline = {n: reports[n].sent for n in answered} if whole else None
        self._channel_base = None
        if whole and all(reports[n].channels is not None for n in answered):
            if settled is None:
                settled, _ = self._processes({n: reports[n] for n in answered}, channel_registry.snapshot())
            self._channel_base = (frozenset(answered), settled)
        wall = time.monotonic() - t0
        st = self.stats
        st.steps += 1
        st.waves += waves
        st.wall_s += wall
        st.max_wall_s = max(st.max_wall_s, wall)
        return BarrierResult(step=step, waves=waves, participants=answered, skipped=tuple(sorted(skipped)),
                             silent=silent_now, wall_s=wall)
