"""Module lifecycle: session, blackboard client, sim clock, liveliness, heartbeat, clean shutdown."""

from __future__ import annotations

import asyncio
import logging
import os
import signal
import socket
import sys
import time
from typing import Any, Awaitable, Callable, TextIO

from wire.network import NetworkConfig
from wire.aio import Link
from wire.health import process_usage
from wire.lockstep import Participant, lockstep_enabled, participant_name
from wire.session import session_stats, traffic
from runtime.clock import SimClock
from runtime.heartbeat import ClockPayloadError, decode_clock, encode_heartbeat
from wire.keys import ModuleKeys
from wire.network import check_chunk as check_name
from modules.vocabulary import Heartbeat
from wire.ratelimit import warn_limited

__all__ = ["ModuleRuntime", "ModuleMain", "run_module", "run_module_async", "READY_PREFIX"]

log = logging.getLogger(__name__)

#: The line a module prints on stdout once it is ready: "SIDEWALK-READY <module>".
READY_PREFIX = "SIDEWALK-READY"

#: What a module provides: an async function of its runtime; returning ends the module.
ModuleMain = Callable[["ModuleRuntime"], Awaitable[None]]


class ModuleRuntime:
    """What a running module gets: its name, network, keys, Zenoh link, blackboard client and sim clock.

    `bb` is None when the module runs without a blackboard (`use_blackboard=False`).
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
        self._ready = False
        self._seq = 0
        self._stdout = stdout if stdout is not None else sys.stdout
        self._host = socket.gethostname()

    # ---- lifecycle -----------------------------------------------------------------------

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

    # ---- internals -----------------------------------------------------------------------

    def _on_clock(self, _key: str, payload: bytes) -> None:
        try:
            self.clock.advance(decode_clock(payload))
        except ClockPayloadError as exc:
            warn_limited(log, "clock-sample", "bad sim clock sample: %.200s", exc)

    def _feed_clock(self, _key: str, payload: bytes, loop: asyncio.AbstractEventLoop) -> None:
        """Real time: take a clock tick on the Zenoh thread (`SimClock.feed`)."""
        try:
            self.clock.feed(decode_clock(payload), loop)
        except ClockPayloadError as exc:
            warn_limited(log, "clock-sample", "bad sim clock sample: %.200s", exc)

    def _beat(self, state: str | None = None) -> None:
        hb = Heartbeat(
            module=self.name, seq=self._seq, sim_time=self.clock.now() if self.clock.running else None,
            wall_time=time.time(), period_s=self.heartbeat_period, pid=os.getpid(), host=self._host,
            state=state or ("ready" if self._ready else "starting"), zenoh_sessions=session_stats()["open"],
            usage=process_usage(traffic()),
            **self._blackboard_health(),
        )
        self._seq += 1
        self.link.put(self.keys.heartbeat(self.name), encode_heartbeat(hb))

    def _blackboard_health(self) -> dict[str, Any]:
        bb = self.bb
        if bb is None or not hasattr(bb, "link_state"):
            return {}
        return {"blackboard": bb.link_state, "monitors": bb.monitor_count, "resyncs": bb.resyncs}

    async def _heartbeat_loop(self) -> None:
        while True:
            self._beat()
            await asyncio.sleep(self.heartbeat_period)  # wall time: a heartbeat tells a wedged process apart


async def _connect_blackboard(rt: ModuleRuntime, connect_timeout: float) -> Any:
    from blackboard import BlackboardClient  # the client lives in the blackboard package

    try:
        return await BlackboardClient.connect(rt.net, source=rt.name, connect_timeout=connect_timeout)
    except Exception as exc:
        raise RuntimeError(f"{rt.name}: cannot reach the blackboard node: {exc}") from exc


async def run_module_async(name: str, main: ModuleMain, net: NetworkConfig, *, use_blackboard: bool = True,
                           heartbeat_period: float = 1.0, connect_timeout: float = 30.0,
                           install_signals: bool = True, stdout: TextIO | None = None) -> int:
    """Run `main(runtime)` as module `name` until it returns or SIGINT/SIGTERM; return the exit code.

    Opens the Zenoh session, subscribes to the sim clock, publishes heartbeats every
    `heartbeat_period` wall seconds [s], connects the blackboard client (waiting up to
    `connect_timeout` [s] for the node), and closes everything explicitly on the way out.
    In lock-step (`wire.lockstep`), the module takes part in the simulator's barrier.
    """
    loop = asyncio.get_running_loop()
    link = Link.open(net)
    rt = ModuleRuntime(name, net, link, heartbeat_period=heartbeat_period, stdout=stdout)
    participant = Participant(link.session, participant_name(name)) if lockstep_enabled() else None
    hb_task: asyncio.Task[None] | None = None
    main_task: asyncio.Task[None] | None = None
    stop_task: asyncio.Task[bool] | None = None
    installed: list[int] = []
    code = 0
    try:
        if participant is not None:  # lock-step: every tick is handled on the loop, where the barrier sees it
            link.subscribe(rt.keys.sim_clock, rt._on_clock)
        else:
            link.subscribe_feed(rt.keys.sim_clock, rt._feed_clock)
        hb_task = loop.create_task(rt._heartbeat_loop())
        if install_signals:
            for sig in (signal.SIGINT, signal.SIGTERM):
                try:
                    loop.add_signal_handler(sig, rt.request_stop)
                    installed.append(sig)
                except (NotImplementedError, RuntimeError):  # not the main thread
                    pass

        async def body() -> None:
            # never say ready (or wait for the node) while connected to nothing: say so and keep trying
            await asyncio.to_thread(link.session.wait_connected, None, name=name, cancelled=rt.stop_event.is_set)
            if use_blackboard:
                rt.bb = await _connect_blackboard(rt, connect_timeout)
                if participant is not None:
                    participant.add_probe(lambda: rt.bb.awaiting_acks)
            await main(rt)

        main_task = loop.create_task(body())
        stop_task = loop.create_task(rt.stop_event.wait())
        done, _ = await asyncio.wait({main_task, stop_task}, return_when=asyncio.FIRST_COMPLETED)
        stop_task.cancel()
        if main_task in done:
            exc = main_task.exception()
            if exc is not None:
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
        if hb_task is not None:
            hb_task.cancel()
        try:
            if link is not None and not link.closed:
                rt._beat("stopping")
        except Exception:
            pass
        if rt.bb is not None:
            try:
                await rt.bb.close()
            except Exception as exc:
                log.warning("%s: closing the blackboard client failed: %s", name, exc)
        if participant is not None:
            participant.close()
        link.close()
    return code


def run_module(name: str, main: ModuleMain, net: NetworkConfig, **kwargs: Any) -> int:
    """Run module `name` in a fresh event loop (see `run_module_async`); return the exit code."""
    return asyncio.run(run_module_async(name, main, net, **kwargs))
