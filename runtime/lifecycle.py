"""The one module runtime of both architectures: session, sim clock, liveliness, heartbeat, lock-step, clean shutdown.

Every process of a Sidewalk system (CODGER's services, EDDIE's modules, the recorder) runs as
`run_module(name, main, net, parts=…)`: the runtime opens the process's one Zenoh session, follows the
simulator's clock, declares the liveliness token and beats every `heartbeat_period` wall seconds
once `ready()` is said (and before), takes part in the lock-step barrier when the run is in
lock-step (`wire.lockstep`), waits until the session reaches the network, starts its optional
*parts*, runs `main(rt)` until it returns or SIGINT/SIGTERM, and closes everything explicitly on the
way out (an unclosed Zenoh session hangs interpreter exit).

A part (`RuntimePart`) is what one architecture plugs in: CODGER's blackboard client
(`codger.blackboard_part`: connected before `main`, its link state in every heartbeat, a lock-step
probe for its unacknowledged writes), EDDIE's point-to-point endpoint (`eddie.toolkit.module`: the
inbox and streams released at each lock-step tick through `on_tick`). The runtime itself knows
neither.
"""

from __future__ import annotations

import asyncio
import logging
import os
import signal
import socket
import sys
import time
from typing import Any, Awaitable, Callable, Protocol, Sequence, TextIO

from runtime.clock import SimClock
from runtime.heartbeat import ClockPayloadError, decode_clock
from wire.aio import Link
from wire.health import Heartbeat, encode_heartbeat, process_usage
from wire.keys import ModuleKeys
from wire.lifeline import dump_stacks_on_request
from wire.lockstep import Participant, lockstep_enabled, participant_name
from wire.network import NetworkConfig
from wire.network import check_chunk as check_name
from wire.ratelimit import warn_limited
from wire.session import barrier_traffic, session_stats, traffic

__all__ = ["ModuleRuntime", "ModuleMain", "RuntimePart", "run_module", "run_module_async", "READY_PREFIX"]

log = logging.getLogger(__name__)

#: The line a module prints on stdout once it is ready: "SIDEWALK-READY <module>".
READY_PREFIX = "SIDEWALK-READY"

#: What a module provides: an async function of its runtime; returning ends the module.
ModuleMain = Callable[["ModuleRuntime"], Awaitable[None]]


class RuntimePart(Protocol):
    """An optional part of the runtime an architecture plugs in (the blackboard client, EDDIE's endpoint)."""

    async def start(self, rt: "ModuleRuntime") -> None:
        """Start once the session reaches the network, before the module's main runs."""

    def health(self) -> dict[str, Any]:
        """Return the fields this part adds to every heartbeat (empty: none)."""

    async def close(self) -> None:
        """Close on the way out, before the session closes."""


class ModuleRuntime:
    """What a running module gets: its name, network, keys, Zenoh link, sim clock, and the parts plugged in.

    `bb` is the blackboard client when CODGER's blackboard part is plugged in (None otherwise).
    `start()` follows the clock and starts the heartbeat (and, in lock-step, the barrier participant);
    `close()` says `stopping` and closes the parts (the caller closes the link it opened).
    """

    def __init__(self, name: str, net: NetworkConfig, link: Link, *, heartbeat_period: float = 1.0,
                 stdout: TextIO | None = None) -> None:
        self.name = check_name(name, "module name")
        self.net = net
        self.keys = ModuleKeys(net.namespace)
        self.link = link
        self.clock = SimClock()
        self.bb: Any = None
        self.heartbeat_period = heartbeat_period
        self.stop_event = asyncio.Event()
        self.parts: list[RuntimePart] = []
        self._ready = False
        self._seq = 0
        self._stdout = stdout if stdout is not None else sys.stdout
        self._host = socket.gethostname()
        self._ticks: list[Callable[[], None]] = []
        self._participant: Participant | None = None
        self._hb_task: asyncio.Task[None] | None = None

    # ---- lifecycle -----------------------------------------------------------------------

    def start(self) -> None:
        """Follow the sim clock, beat once now and every `heartbeat_period` [s wall], and join the lock-step barrier."""
        if lockstep_enabled():  # lock-step: every tick is handled on the loop, where the barrier sees it
            self._participant = Participant(self.link.session, participant_name(self.name))
            self.link.subscribe(self.keys.sim_clock, self._on_clock)
        else:
            self.link.subscribe_feed(self.keys.sim_clock, self._feed_clock)
        self._beat()
        self._hb_task = asyncio.get_running_loop().create_task(self._heartbeat_loop())

    async def plug(self, part: RuntimePart) -> None:
        """Start `part` now and keep it: its health in every heartbeat, closed on the way out."""
        await part.start(self)
        self.parts.append(part)

    async def close(self) -> None:
        """Stop beating, say `stopping`, close the parts (newest first) and leave the barrier (idempotent)."""
        if self._hb_task is not None:
            self._hb_task.cancel()
            self._hb_task = None
        try:
            if not self.link.closed:
                self._beat("stopping")
        except Exception:  # noqa: BLE001 - closing anyway
            pass
        while self.parts:
            part = self.parts.pop()
            try:
                await part.close()
            except Exception as exc:  # noqa: BLE001 - closing anyway
                log.warning("%s: closing %s failed: %s", self.name, type(part).__name__, exc)
        if self._participant is not None:
            self._participant.close()
            self._participant = None

    @property
    def is_ready(self) -> bool:
        """Return whether `ready()` has been called."""
        return self._ready

    def ready(self) -> None:
        """Declare the module ready: liveliness token, a ready heartbeat, and the READY line on stdout."""
        if self._ready:
            return
        self._ready = True
        self.link.declare_alive(self.keys.alive(self.name))
        self._beat()
        print(f"{READY_PREFIX} {self.name}", file=self._stdout, flush=True)
        log.info("%s ready (ns %s)", self.name, self.net.namespace)

    def request_stop(self) -> None:
        """Ask the module to stop (as SIGINT/SIGTERM do)."""
        self.stop_event.set()

    @property
    def stopping(self) -> bool:
        """Return whether a stop has been requested."""
        return self.stop_event.is_set()

    def now(self) -> float | None:
        """Return the sim time [s], or None before the simulator's first clock tick."""
        return self.clock.now() if self.clock.running else None

    # ---- lock-step -----------------------------------------------------------------------

    def on_tick(self, release: Callable[[], None]) -> None:
        """Call `release()` on the loop after each lock-step clock tick (what arrived before it is handed over then)."""
        self._ticks.append(release)

    def add_probe(self, busy: Callable[[], int]) -> None:
        """Have the lock-step barrier also wait while `busy()` is non-zero (writes not yet acknowledged); no-op in real time."""
        if self._participant is not None:
            self._participant.add_probe(busy)

    # ---- internals -----------------------------------------------------------------------

    def _on_clock(self, _key: str, payload: bytes) -> None:
        try:
            self.clock.advance(decode_clock(payload))
        except ClockPayloadError as exc:
            warn_limited(log, "clock-sample", "%s: bad sim clock sample: %.200s", self.name, exc)
            return
        for release in self._ticks:
            release()

    def _feed_clock(self, _key: str, payload: bytes, loop: asyncio.AbstractEventLoop) -> None:
        """Real time: take a clock tick on the Zenoh thread (`SimClock.feed`)."""
        try:
            self.clock.feed(decode_clock(payload), loop)
        except ClockPayloadError as exc:
            warn_limited(log, "clock-sample", "%s: bad sim clock sample: %.200s", self.name, exc)

    def _beat(self, state: str | None = None) -> None:
        health: dict[str, Any] = {}
        for part in self.parts:
            health.update(part.health())
        hb = Heartbeat(
            module=self.name, seq=self._seq, sim_time=self.now(), wall_time=time.time(), period_s=self.heartbeat_period,
            pid=os.getpid(), host=self._host, state=state or ("ready" if self._ready else "starting"),
            zenoh_sessions=session_stats()["open"], usage=process_usage(traffic(), barrier_traffic()), **health,
        )
        self._seq += 1
        self.link.put(self.keys.heartbeat(self.name), encode_heartbeat(hb))

    async def _heartbeat_loop(self) -> None:
        while not self.link.closed:
            await asyncio.sleep(self.heartbeat_period)  # wall time: a heartbeat tells a wedged process apart
            self._beat()


async def run_module_async(name: str, main: ModuleMain, net: NetworkConfig, *, parts: Sequence[RuntimePart] = (),
                           heartbeat_period: float = 1.0, install_signals: bool = True, stdout: TextIO | None = None) -> int:
    """Run `main(runtime)` as module `name` until it returns or SIGINT/SIGTERM; return the exit code (1: it failed).

    Opens the Zenoh session, follows the sim clock, beats every `heartbeat_period` wall seconds [s],
    waits (saying so) until the session reaches the network, starts `parts` in order, runs `main`,
    and closes everything explicitly on the way out.
    """
    loop = asyncio.get_running_loop()
    link = Link.open(net)
    rt = ModuleRuntime(name, net, link, heartbeat_period=heartbeat_period, stdout=stdout)
    main_task: asyncio.Task[None] | None = None
    stop_task: asyncio.Task[bool] | None = None
    installed: list[int] = []
    code = 0
    try:
        rt.start()
        if install_signals:
            for sig in (signal.SIGINT, signal.SIGTERM):
                try:
                    loop.add_signal_handler(sig, rt.request_stop)
                    installed.append(sig)
                except (NotImplementedError, RuntimeError):  # not the main thread
                    pass
            dump_stacks_on_request()

        async def body() -> None:
            # never say ready (or start a part) while connected to nothing: say so and keep trying
            await asyncio.to_thread(link.session.wait_connected, None, name=name, cancelled=rt.stop_event.is_set)
            for part in parts:
                await rt.plug(part)
            await main(rt)

        main_task = loop.create_task(body())
        stop_task = loop.create_task(rt.stop_event.wait())
        done, _ = await asyncio.wait({main_task, stop_task}, return_when=asyncio.FIRST_COMPLETED)
        stop_task.cancel()
        if main_task in done:
            exc = None if main_task.cancelled() else main_task.exception()
            if main_task.cancelled():
                print(f"{name}: error: its main was cancelled", file=sys.stderr, flush=True)
                code = 1
            elif exc is not None:
                log.error("%s failed: %s", name, exc, exc_info=exc)
                print(f"{name}: error: {exc}", file=sys.stderr, flush=True)
                code = 1
        else:
            log.info("%s: stop requested", name)
            main_task.cancel()
            try:
                await asyncio.wait_for(main_task, 5.0)
            except (asyncio.CancelledError, asyncio.TimeoutError):
                pass
            except Exception as exc:
                log.warning("%s raised while stopping: %s", name, exc)
    finally:
        for sig in installed:
            loop.remove_signal_handler(sig)
        if stop_task is not None:
            stop_task.cancel()
        if main_task is not None and not main_task.done():  # the runner itself was cancelled
            main_task.cancel()
            try:
                await asyncio.wait({main_task}, timeout=5.0)
            except asyncio.CancelledError:
                pass
        await rt.close()
        link.close()
    return code


def run_module(name: str, main: ModuleMain, net: NetworkConfig, **kwargs: Any) -> int:
    """Run module `name` in a fresh event loop (see `run_module_async`); return the exit code."""
    return asyncio.run(run_module_async(name, main, net, **kwargs))
