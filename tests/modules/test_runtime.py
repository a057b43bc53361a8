"""Runtime: sim clock semantics, clock/heartbeat decoding, keys, and a module's lifecycle over real Zenoh."""

from __future__ import annotations

import asyncio
import io
import json
import os
import signal
import sys
from pathlib import Path

import msgpack
import pytest

from runtime import (
    READY_PREFIX, ClockNotRunningError, ClockPayloadError, HeartbeatError, HeartbeatTracker, ModuleKeys, QueryAnswer,
    SimClock, Link, decode_clock, decode_heartbeat, encode_heartbeat, run_module_async,
)
from wire.health import Heartbeat
from tests.modules._net import net_pair

ROOT = Path(__file__).resolve().parents[2]


# ---- sim clock (pure) -------------------------------------------------------------------------


async def test_clock_wakes_sleepers_in_sim_time_order() -> None:
    clock = SimClock()
    with pytest.raises(ClockNotRunningError):
        clock.now()
    woke: list[str] = []

    async def sleeper(tag: str, dt: float) -> None:
        await clock.sleep(dt)
        woke.append(tag)

    tasks = [asyncio.create_task(sleeper("b", 2.0)), asyncio.create_task(sleeper("a", 1.0))]
    await asyncio.sleep(0)  # let both register (they wait for the first tick)
    clock.advance(10.0)
    await asyncio.sleep(0)
    assert woke == []
    clock.advance(10.5)
    clock.advance(11.0)
    await asyncio.wait_for(tasks[1], 1.0)
    assert woke == ["a"]
    clock.advance(12.0)
    await asyncio.wait_for(tasks[0], 1.0)
    assert woke == ["a", "b"]
    assert clock.now() == 12.0


async def test_wait_until_past_returns_at_once_and_late_ticks_are_ignored() -> None:
    clock = SimClock()
    clock.advance(5.0)
    assert await clock.wait_until(3.0) == 5.0
    clock.advance(4.8)  # a late, out-of-order tick
    assert clock.now() == 5.0


async def test_clock_restart_rebases_pending_sleeps() -> None:
    clock = SimClock(reset_s=1.0)
    clock.advance(100.0)
    task = asyncio.create_task(clock.sleep(3.0))
    await asyncio.sleep(0)
    clock.advance(0.0)  # simulator restarted: the sleep now ends at 3.0
    clock.advance(2.9)
    await asyncio.sleep(0)
    assert not task.done()
    clock.advance(3.0)
    assert await asyncio.wait_for(task, 1.0) == 3.0


async def test_wait_for_times_out_in_sim_time() -> None:
    clock = SimClock()
    clock.advance(0.0)
    never = asyncio.get_running_loop().create_future()
    task = asyncio.create_task(clock.wait_for(never, 2.0))
    await asyncio.sleep(0)
    clock.advance(1.0)
    await asyncio.sleep(0)
    assert not task.done()
    clock.advance(2.0)
    with pytest.raises(TimeoutError):
        await asyncio.wait_for(task, 1.0)
    assert never.cancelled()

    fut = asyncio.get_running_loop().create_future()
    task = asyncio.create_task(clock.wait_for(fut, 2.0))
    await asyncio.sleep(0)
    fut.set_result(7)
    assert await asyncio.wait_for(task, 1.0) == 7


class _CountingLoop:
    """The running loop, counting what a feeding thread hands to it."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self.loop = loop
        self.handed = 0

    def call_soon_threadsafe(self, fn, *args):  # noqa: ANN001, ANN201 - the loop's signature
        self.handed += 1
        return self.loop.call_soon_threadsafe(fn, *args)


async def _feed_from_thread(clock: SimClock, loop: _CountingLoop, ticks: list[float]) -> None:
    """Feed `ticks` in order from a thread of their own, as Zenoh's does; return once what they handed the loop ran
    (it was queued before this coroutine's own wake-up)."""
    await asyncio.to_thread(lambda: [clock.feed(t, loop) for t in ticks])  # type: ignore[arg-type]


async def _sleeping(clock: SimClock, sim_s: float) -> asyncio.Task:
    """Start `clock.sleep(sim_s)` in a task; return it once the sleep is registered."""
    registered = asyncio.Event()

    async def sleeper() -> float:
        registered.set()
        return await clock.sleep(sim_s)  # registers before it first yields

    task = asyncio.create_task(sleeper())
    await registered.wait()
    return task


async def test_fed_ticks_set_the_time_and_call_the_loop_only_to_wake_a_sleeper() -> None:
    clock = SimClock()
    loop = _CountingLoop(asyncio.get_running_loop())
    await _feed_from_thread(clock, loop, [10.0])  # the first tick goes through the loop (it starts the clock)
    assert await asyncio.wait_for(clock.wait_running(), 1.0) == 10.0
    assert loop.handed == 1
    # ticks that wake nobody only set the time: now() is current without the loop doing anything
    await _feed_from_thread(clock, loop, [10.05 + 0.05 * k for k in range(100)])
    assert clock.now() == pytest.approx(15.0) and loop.handed == 1
    task = await _sleeping(clock, 0.2)
    await _feed_from_thread(clock, loop, [15.05, 15.1, 15.15])
    assert not task.done() and loop.handed == 1
    await _feed_from_thread(clock, loop, [15.2, 15.25, 15.3])  # 15.2 is due: one call, the later ticks none
    assert await asyncio.wait_for(task, 1.0) >= 15.2 - 1e-9
    assert loop.handed == 2
    # a late tick is dropped; a restart goes through the loop and re-bases what sleeps
    await _feed_from_thread(clock, loop, [15.1])
    assert clock.now() == pytest.approx(15.3) and loop.handed == 2
    task = await _sleeping(clock, 3.0)
    await _feed_from_thread(clock, loop, [0.0, 2.9])
    assert clock.now() == pytest.approx(2.9) and not task.done() and clock.pending == 1
    await _feed_from_thread(clock, loop, [3.0])
    assert await asyncio.wait_for(task, 1.0) == pytest.approx(3.0)


async def test_a_sleep_begun_while_the_thread_feeds_is_never_missed() -> None:
    """Sleepers registered from the loop while another thread ticks on: each wakes within one tick of its deadline."""
    clock = SimClock()
    loop = _CountingLoop(asyncio.get_running_loop())
    clock.advance(0.0)
    stop = False
    ticks = 0

    def ticker() -> None:
        nonlocal ticks
        t = 0.0
        while not stop and t < 1e6:
            t += 0.001
            clock.feed(t, loop)  # type: ignore[arg-type]
            ticks += 1

    feeding = asyncio.ensure_future(asyncio.to_thread(ticker))
    try:
        for _ in range(300):
            start = clock.now()
            got = await asyncio.wait_for(clock.sleep(0.002), 5.0)
            assert got >= start + 0.002 - 1e-9
    finally:
        stop = True
        await feeding
    assert ticks > 600


async def test_cancelled_sleep_leaves_no_waiter() -> None:
    clock = SimClock()
    clock.advance(0.0)
    task = asyncio.create_task(clock.sleep(5.0))
    await asyncio.sleep(0)
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    assert clock.pending == 0


# ---- wire decoding (pure) --------------------------------------------------------------------


@pytest.mark.parametrize("payload,expected", [
    (msgpack.packb(12.5), 12.5),
    (msgpack.packb(3), 3.0),
    (msgpack.packb({"t": 4.25, "rtf": 10.0}), 4.25),
    (msgpack.packb({"sim_time": 1.5}), 1.5),
    (json.dumps({"time": 2.0}).encode(), 2.0),
    (b"17.75", 17.75),
])
def test_decode_clock_accepts_numbers_and_maps(payload: bytes, expected: float) -> None:
    assert decode_clock(payload) == expected


@pytest.mark.parametrize("payload,match", [
    (msgpack.packb({"speed": 1.0}), "none of the fields"),
    (msgpack.packb([1, 2]), "must be a number"),
    (b"\xc1garbage{", "neither msgpack nor JSON"),
    (msgpack.packb(True), "must be a number"),
])
def test_decode_clock_rejects_with_reason(payload: bytes, match: str) -> None:
    with pytest.raises(ClockPayloadError, match=match):
        decode_clock(payload)


def test_heartbeat_round_trip_and_bad_payload() -> None:
    hb = Heartbeat(module="pilot", seq=3, sim_time=1.0, wall_time=5.0, period_s=0.5, pid=1)
    assert decode_heartbeat(encode_heartbeat(hb)) == hb
    with pytest.raises(HeartbeatError, match="module"):
        decode_heartbeat(msgpack.packb({"seq": 1}))


def test_tracker_flags_modules_that_went_quiet() -> None:
    tr = HeartbeatTracker(grace=3.0)
    tr.observe(Heartbeat(module="helm", seq=0, wall_time=0.0, period_s=0.1, pid=1), wall=100.0)
    tr.observe(Heartbeat(module="captain", seq=0, wall_time=0.0, period_s=1.0, pid=2), wall=100.0)
    assert tr.stale(wall=100.2) == ()
    assert tr.stale(wall=100.5) == ("helm",)
    assert tr.stale(wall=104.0) == ("captain", "helm")
    assert tr.modules() == ("captain", "helm")


def test_keys_are_namespaced_and_checked() -> None:
    k = ModuleKeys("lab")
    assert k.alive("pilot") == "sidewalk/lab/alive/pilot"
    assert k.heartbeat("pilot") == "sidewalk/lab/heartbeat/pilot"
    assert k.sim_clock == "sidewalk/lab/sim/clock"
    assert k.mission_status("m-1") == "sidewalk/lab/mission/status/m-1"
    with pytest.raises(ValueError, match="module name"):
        k.alive("pi/lot")
    with pytest.raises(ValueError, match="namespace"):
        ModuleKeys("a b")


# ---- lifecycle over real Zenoh ---------------------------------------------------------------


async def test_module_lifecycle_over_zenoh() -> None:
    """A module becomes alive, beats, sleeps in sim time, answers a query, and leaves cleanly."""
    listen, connect, _ = net_pair("rt1")
    keys = ModuleKeys("rt1")
    peer = Link.open(listen)
    try:
        alive: asyncio.Queue[tuple[str, bool]] = asyncio.Queue()
        beats: asyncio.Queue[Heartbeat] = asyncio.Queue()
        peer.watch_alive(keys.alive_all, lambda k, a: alive.put_nowait((k, a)))
        peer.subscribe(keys.heartbeat_all, lambda k, p: beats.put_nowait(decode_heartbeat(p)))
        slept = asyncio.Event()
        out = io.StringIO()

        holder: dict = {}

        async def main(rt) -> None:
            holder["rt"] = rt

            async def echo(req):
                return QueryAnswer(ok=True, payload=req.payload[::-1])

            rt.link.queryable(f"{rt.keys.root}/echo", echo)
            rt.ready()
            await rt.clock.sleep(2.0)
            slept.set()
            await rt.stop_event.wait()

        task = asyncio.create_task(run_module_async("tester", main, connect,
                                                    heartbeat_period=0.05, install_signals=False, stdout=out))
        assert await asyncio.wait_for(alive.get(), 10.0) == (keys.alive("tester"), True)
        assert f"{READY_PREFIX} tester" in out.getvalue()
        hb = await asyncio.wait_for(beats.get(), 10.0)
        assert hb.module == "tester" and hb.pid == os.getpid()
        while hb.state != "ready":
            hb = await asyncio.wait_for(beats.get(), 10.0)

        replies = await peer.get(f"{keys.root}/echo", payload=b"abc", timeout=5.0)
        assert [(r.ok, r.payload) for r in replies] == [(True, b"cba")]

        # sim time: ticks drive the module's sleep; the heartbeat carries the sim stamp
        peer.put(keys.sim_clock, msgpack.packb({"t": 10.0}))
        while True:
            hb = await asyncio.wait_for(beats.get(), 10.0)
            if hb.sim_time == 10.0:
                break
        assert not slept.is_set()
        peer.put(keys.sim_clock, msgpack.packb({"t": 12.0}))
        await asyncio.wait_for(slept.wait(), 10.0)

        # stop requested (what SIGTERM does): the liveliness token goes away and the runner returns 0
        holder["rt"].request_stop()
        assert await asyncio.wait_for(task, 10.0) == 0
        assert await asyncio.wait_for(alive.get(), 10.0) == (keys.alive("tester"), False)
        assert holder["rt"].link.closed
    finally:
        peer.close()


_CHILD = """
import asyncio, sys
from wire.network import NetworkConfig
from runtime import run_module

async def main(rt):
    rt.ready()
    await asyncio.Event().wait()

sys.exit(run_module("child", main, NetworkConfig(namespace="rt2", connect=(sys.argv[1],)),
                    heartbeat_period=0.1))
"""


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
async def test_module_process_shuts_down_cleanly_on_signal(sig: signal.Signals) -> None:
    """A module process exits 0 on SIGTERM/SIGINT, its session closed and its token withdrawn."""
    listen, _, ep = net_pair("rt2")
    keys = ModuleKeys("rt2")
    peer = Link.open(listen)
    proc = await asyncio.create_subprocess_exec(sys.executable, "-c", _CHILD, ep, cwd=str(ROOT),
                                                stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    try:
        alive: asyncio.Queue[tuple[str, bool]] = asyncio.Queue()
        peer.watch_alive(keys.alive_all, lambda k, a: alive.put_nowait((k, a)))
        line = await asyncio.wait_for(proc.stdout.readline(), 20.0)
        assert line.decode().strip() == f"{READY_PREFIX} child"
        assert await asyncio.wait_for(alive.get(), 10.0) == (keys.alive("child"), True)
        assert await peer.alive_keys(keys.alive_all) == [keys.alive("child")]
        proc.send_signal(sig)
        assert await asyncio.wait_for(proc.wait(), 15.0) == 0
        assert await asyncio.wait_for(alive.get(), 10.0) == (keys.alive("child"), False)
    finally:
        if proc.returncode is None:
            proc.kill()
            await proc.wait()
        peer.close()


def test_decode_clock_reads_the_simulators_clock_message() -> None:
    from wire.drive import SimClock as SimClockMsg
    from wire.drive import encode

    assert decode_clock(encode(SimClockMsg(stamp=42.5, rtf=20.0, rtf_actual=19.5, step=850))) == 42.5
    assert decode_clock(encode(SimClockMsg(stamp=1.25, rtf=1.0, rtf_actual=1.0, step=25), as_json=True)) == 1.25
