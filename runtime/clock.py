"""The simulation clock as seen by a module: sim time [s] fed by the simulator's clock ticks."""

from __future__ import annotations

import asyncio
import heapq
import itertools
import logging
import math
from typing import Awaitable, TypeVar
from runtime.errors import ModuleRuntimeError
from wire.ratelimit import warn_limited

__all__ = ["SimClock", "ClockNotRunningError"]

log = logging.getLogger(__name__)
T = TypeVar("T")


class ClockNotRunningError(ModuleRuntimeError, RuntimeError):
    """No sim clock tick has been received yet, so there is no sim time."""


class SimClock:
    """Sim time [s] as last published by the simulator; sleeps and deadlines in sim time.

    Two ways in. `advance(t)` runs on the event loop thread (lock-step hands every tick over that
    way, so the barrier sees each one handled). `feed(t, loop)` runs on the Zenoh thread in real
    time: a tick that wakes no sleeper only sets the time, and the loop is called
    (`call_soon_threadsafe`) only for one that does, for the first tick and for a restart. At RTF 50
    the simulator ticks 1000 times a second [wall], and a loop woken for each cost every module a
    few percent of a core for nothing. Time never runs backwards here: a tick older than `now()`
    by more than `reset_s` [s] is taken as a simulator restart and pending sleeps are re-based.
    """

    def __init__(self, *, reset_s: float = 1.0) -> None:
        self._now: float | None = None
        self._reset_s = reset_s
        self._heap: list[tuple[float, int, asyncio.Future[None]]] = []
        self._seq = itertools.count()
        self._started: asyncio.Event | None = None
        #: a wake is on its way to the loop (`feed`): later due ticks need not send another
        self._wake_sent = False
        self.ticks = 0

    # ---- feeding --------------------------------------------------------------------------

    def advance(self, t: float) -> None:
        """Set sim time to `t` [s] and wake every sleeper whose deadline has passed."""
        if not math.isfinite(t):
            warn_limited(log, "clock-nonfinite", "ignoring non-finite sim clock tick %r", t)
            return
        if self._now is not None and t < self._now:
            if self._now - t <= self._reset_s:
                return  # a late, out-of-order tick
            log.warning("sim clock went back from %.3f to %.3f s: simulator restarted", self._now, t)
            shift = t - self._now
            self._heap = [(d + shift, s, f) for d, s, f in self._heap]
            heapq.heapify(self._heap)
        self._now = t
        self.ticks += 1
        self._release()

    def feed(self, t: float, loop: asyncio.AbstractEventLoop) -> None:
        """Take tick `t` [s] on any thread (never blocks); call the loop only when it has something to do."""
        now = self._now
        if now is None or not t >= now:
            if now is not None and now - t <= self._reset_s:
                return  # a late, out-of-order tick
            loop.call_soon_threadsafe(self.advance, t)  # the first tick, a restart, a non-finite one: the loop's rule
            return
        if not math.isfinite(t):
            loop.call_soon_threadsafe(self.advance, t)
            return
        self._now = t
        self.ticks += 1
        try:
            due = self._heap[0][0] <= t
        except IndexError:  # nobody sleeps (the loop may pop the last one meanwhile)
            return
        if due and not self._wake_sent:
            self._wake_sent = True
            loop.call_soon_threadsafe(self._release)

    def _release(self) -> None:
        """Wake every sleeper whose deadline has passed (loop thread)."""
        self._wake_sent = False
        if self._started is not None and not self._started.is_set():
            self._started.set()
        t = self._now
        while self._heap and self._heap[0][0] <= t:
            _, _, fut = heapq.heappop(self._heap)
            if not fut.done():
                fut.set_result(None)

    # ---- reading --------------------------------------------------------------------------

    @property
    def pending(self) -> int:
        """Return the number of sleepers waiting for a future sim time."""
        return len(self._heap)

    @property
    def running(self) -> bool:
        """Return whether at least one tick has arrived."""
        return self._now is not None

    def now(self) -> float:
        """Return the current sim time [s]; raise ClockNotRunningError before the first tick."""
        if self._now is None:
            raise ClockNotRunningError("no sim clock tick received yet (is the simulator running?)")
        return self._now

    def now_or(self, default: float) -> float:
        """Return the current sim time [s], or `default` before the first tick."""
        return default if self._now is None else self._now

    def _event(self) -> asyncio.Event:
        if self._started is None:
            self._started = asyncio.Event()
            if self._now is not None:
                self._started.set()
        return self._started

    async def wait_running(self, timeout: float | None = None) -> float:
        """Wait until the first tick arrives (timeout in wall seconds [s]); return sim time [s]."""
        await asyncio.wait_for(self._event().wait(), timeout)
        return self.now()

    async def wait_until(self, t: float) -> float:
        """Wait until sim time reaches `t` [s] (waits for the clock to start first); return sim time [s]."""
        if self._now is not None and self._now >= t:
            return self._now
        fut: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        heapq.heappush(self._heap, (t, next(self._seq), fut))
        if self._now is not None and self._now >= t:
            # a tick fed on the Zenoh thread between the test above and the push saw no sleeper due
            self._release()
        try:
            await fut
        finally:
            if not fut.done() or fut.cancelled():
                fut.cancel()
                self._heap = [e for e in self._heap if e[2] is not fut]
                heapq.heapify(self._heap)
        return self.now()

    async def sleep(self, sim_s: float) -> float:
        """Sleep `sim_s` [s] of sim time from now (from the first tick if not started); return sim time [s]."""
        if self._now is None:
            await self.wait_running()
        return await self.wait_until(self.now() + max(0.0, sim_s))

    async def wait_for(self, aw: Awaitable[T], sim_s: float) -> T:
        """Await `aw` with a timeout of `sim_s` [s] sim time; raise TimeoutError when it expires."""
        task = asyncio.ensure_future(aw)
        timer = asyncio.ensure_future(self.sleep(sim_s))
        try:
            done, _ = await asyncio.wait({task, timer}, return_when=asyncio.FIRST_COMPLETED)
            if task in done:
                return task.result()
            task.cancel()
            try:
                await task
            except BaseException:
                pass
            raise TimeoutError(f"no result within {sim_s:.3f} s of sim time")
        finally:
            timer.cancel()
            if not task.done():
                task.cancel()
