"""The lock-step barrier against real participant processes on loopback Zenoh (multicast off).

Each test starts participants (`tests.wire.lockstep_participant`) connected to this process's router
session and holds the simulator's side, a `Barrier`, here. Synchronised on READY lines, liveliness
and the barrier itself; a test never sleeps.
"""

from __future__ import annotations

import asyncio
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator

import pytest

from tests._procs import wait_stopped
from wire.keys import LockstepKeys
from wire.lockstep import Barrier, BarrierAsk, BarrierResult, ParticipantReport, _CountingExecutor, decode, encode
from wire.network import NetworkConfig
from wire.ports import free_port
from wire.session import Session, open_session

NS = "lockstep_test"


class Net:
    """This process's router session, the barrier on it, and the participant processes started."""

    def __init__(self) -> None:
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.session: Session = open_session(NetworkConfig(namespace=NS, mode="router", listen=(self.endpoint,)))
        self.procs: list[subprocess.Popen] = []
        self.barrier = Barrier(self.session, timeout_s=0.5, busy_limit_s=10.0)

    def start(self, name: str, *extra: str) -> tuple[subprocess.Popen, str]:
        """Start participant `name`; return its process and participant name once it is a barrier member."""
        p = subprocess.Popen([sys.executable, "-m", "tests.wire.lockstep_participant", name, self.endpoint, NS, *extra],
                             stdout=subprocess.PIPE, text=True)
        self.procs.append(p)
        line = p.stdout.readline().split()  # blocks until READY (the test's timeout bounds it)
        assert line[:1] == ["READY"], f"participant {name} did not start: {line}"
        pname = line[1]
        assert self.barrier.wait_members(lambda m: pname in m, 10.0), f"{pname} never became a barrier member"
        return p, pname

    def done_event(self, name: str) -> threading.Event:
        """Return an event set when participant `name` says its handler finished."""
        ev = threading.Event()
        self.session.subscribe_payload(f"sidewalk/{NS}/test/done/{name}", lambda *_: ev.set())
        return ev

    def go(self, name: str, reply: str = "") -> None:
        """Start participant `name`'s handler (with `reply`: it ends with a put on `test/done/<reply>`)."""
        self.session.put(f"sidewalk/{NS}/test/go/{name}", reply.encode() or b"x")

    def close(self) -> None:
        for p in self.procs:
            if p.poll() is None:
                os.kill(p.pid, signal.SIGCONT)
                p.terminate()
        for p in self.procs:
            try:
                p.wait(10.0)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.barrier.close()
        self.session.close()


@pytest.fixture
def net() -> Iterator[Net]:
    n = Net()
    try:
        yield n
    finally:
        n.close()


def test_payloads_round_trip_and_bad_ones_are_typed() -> None:
    from wire.lockstep import LockstepPayloadError

    ask = BarrierAsk(seq=7, step=3, wave=1, sim_time=0.15)
    assert decode(BarrierAsk, encode(ask)) == ask
    assert decode(BarrierAsk, ask.model_dump_json().encode(), as_json=True) == ask
    with pytest.raises(LockstepPayloadError):
        decode(ParticipantReport, b"\x93\x01\x02")
    with pytest.raises(ValueError):
        Barrier.__init__(object.__new__(Barrier), None, quiet_waves=1)  # type: ignore[arg-type]


@pytest.mark.timeout(60)
def test_a_participant_busy_with_a_handler_holds_the_barrier(net: Net) -> None:
    net.start("a", "--work", "0.4")
    done = net.done_event("a")
    net.go("a")
    res = net.barrier.wait(1, 0.05)
    # the handler's worker-thread job, and the put it ends with, were waited for
    assert done.is_set(), f"the barrier returned before the handler finished: {res}"
    assert res.skipped == () and res.waves >= 2


@pytest.mark.timeout(60)
def test_a_message_in_flight_between_two_participants_holds_the_barrier(net: Net) -> None:
    net.start("b", "--work", "0.3")
    net.start("a", "--work", "0.3", "--forward", "b")
    done = net.done_event("b")
    net.go("a")
    res = net.barrier.wait(1, 0.05)
    # a's job, a → b, b's job, b → here: all before the barrier let the step go
    assert done.is_set(), f"the barrier returned with a message still between participants: {res}"
    assert res.skipped == () and len(res.participants) == 2


@pytest.mark.timeout(60)  # quiet ~4 s
def test_a_participant_whose_loop_is_held_longer_than_the_time_out_is_waited_for_not_skipped(net: Net) -> None:
    # its loop cannot answer (a long synchronous computation, or a process starved of CPU on a loaded machine); its
    # keeper thread answers busy, so the barrier does not take it for a stopped process while the loop is held
    _p, pname = net.start("a", "--work", "0.1", "--hold")
    done = net.done_event("a")
    busy = threading.Semaphore(0)
    net.session.subscribe_payload(LockstepKeys(NS).report(pname),
                                  lambda _k, b: decode(ParticipantReport, b).busy and busy.release())
    out: dict[str, BarrierResult] = {}
    net.go("a")
    waiting = threading.Thread(target=lambda: out.update(res=net.barrier.wait(1, 0.05)))
    waiting.start()
    held_waves = 3 * round(net.barrier.timeout_s / 0.25)  # each busy answer comes 0.25 s after its ask: 3 time-outs in all
    for _ in range(held_waves):
        assert busy.acquire(timeout=30.0), "the held participant stopped answering busy"
    assert net.barrier.silent() == [] and waiting.is_alive(), "the barrier took the held participant for a stopped one"
    net.session.put(f"sidewalk/{NS}/test/release/a", b"x")
    waiting.join(30.0)
    res = out["res"]
    assert done.is_set(), f"the barrier returned before the held loop finished: {res}"
    assert res.skipped == () and res.silent == () and net.barrier.stats.silenced == 0, res


@pytest.mark.timeout(60)  # quiet ~3 s
def test_after_a_quiet_step_one_wave_is_enough_unless_a_participant_sent_something(net: Net) -> None:
    net.start("b", "--work", "0.2")
    net.start("a", "--work", "0.2", "--forward", "b")
    first = net.barrier.wait(1, 0.05)
    assert first.waves >= 2, "the first step has no quiet step before it: it needs two waves"
    idle = net.barrier.wait(2, 0.10)
    assert idle.waves == 1 and net.barrier.stats.one_wave + net.barrier.stats.by_channels == 1, idle
    done = net.done_event("b")
    net.go("a")
    res = net.barrier.wait(3, 0.15)
    # a's job and its put to b, b's job and its put here: a sent something, so one idle wave was not taken as quiet
    assert done.is_set(), f"the barrier returned with a message still between participants: {res}"
    assert res.waves >= 2 and res.skipped == (), res
    again = net.barrier.wait(4, 0.20)
    assert again.waves == 1, again


@pytest.mark.timeout(60)  # quiet ~3 s
def test_a_participant_answering_the_simulator_with_a_put_takes_one_wave(net: Net) -> None:
    # what the controller does every tick (a drive command back to the simulator): its put reaches the simulator
    # before its answer does, so the channel counts show nothing in flight after one wave (two equal waves before)
    net.start("a", "--work", "0")
    net.barrier.wait(1, 0.05)  # a quiet step: the counts' baseline
    for k in range(3):
        done = net.done_event(f"a{k}")
        net.go("a", reply=f"a{k}")
        res = net.barrier.wait(2 + k, 0.10 + 0.05 * k)
        assert done.is_set(), f"the barrier returned before the answer's put arrived: {res}"
        assert res.waves == 1, (res, net.barrier.stats)
    assert net.barrier.stats.by_channels == 3 and net.barrier.stats.channel_fallbacks == 0, net.barrier.stats


@pytest.mark.timeout(60)  # quiet ~4 s
def test_a_message_still_on_its_way_is_waited_for_by_asking_only_its_receiver(net: Net) -> None:
    net.start("c", "--work", "0.2")
    net.start("b", "--work", "0.2", "--forward", "c")
    net.start("a", "--work", "0.2", "--forward", "b")
    net.barrier.wait(1, 0.05)
    for k in range(3):
        done = net.done_event("c")
        net.go("a")
        res = net.barrier.wait(2 + k, 0.10 + 0.05 * k)
        # a → b → c → here, each after a worker-thread job: the step waits for the whole chain
        assert done.is_set(), f"the barrier returned with a message still between participants: {res}"
        assert res.skipped == () and len(res.participants) == 3, res
    st = net.barrier.stats
    assert st.by_channels >= 1 and st.targeted_waves >= 1, st


@pytest.mark.timeout(60)
def test_a_dead_participant_is_dropped(net: Net) -> None:
    net.start("a", "--work", "0.1")
    p, pname = net.start("c")
    p.kill()
    p.wait()
    assert net.barrier.wait_members(lambda m: pname not in m, 15.0), "the killed participant's token never went"
    res = net.barrier.wait(1, 0.05)
    assert res.skipped == () and pname not in res.participants and len(res.participants) == 1
    assert net.barrier.stats.dropped >= 1


@pytest.mark.timeout(60)
def test_a_stopped_participant_is_skipped_then_not_waited_for_until_it_answers_again(net: Net) -> None:
    net.start("a", "--work", "0.1")
    p, pname = net.start("d")
    os.kill(p.pid, signal.SIGSTOP)
    wait_stopped(p.pid)
    res = net.barrier.wait(1, 0.05)
    assert res.skipped == (pname,), res
    assert net.barrier.stats.skips == 1 and net.barrier.stats.silenced == 1
    assert res.wall_s < 10 * net.barrier.timeout_s  # skipped for the rest of the step, not asked again each wave
    # still stopped: the next steps do not wait for it again (a wedge of 5 s sim lasts 5 s sim, not 5 s of time-outs)
    for step in (2, 3):
        res = net.barrier.wait(step, 0.05 * step)
        assert res.skipped == () and res.silent == (pname,) and pname not in res.participants, res
    assert net.barrier.stats.skips == 1, "a silent participant cost the time-out again"
    os.kill(p.pid, signal.SIGCONT)
    step = 4
    while pname in net.barrier.silent():  # each step probes it once; its idle answer brings it back
        net.barrier.wait(step, 0.05 * step)
        net.barrier.wait_heard(pname, net.barrier.timeout_s + 1.0)
        step += 1
        assert step < 40, "the continued participant never answered a probe"
    res = net.barrier.wait(step, 0.05 * step)
    assert res.skipped == () and res.silent == () and pname in res.participants, res
    assert net.barrier.stats.heard_again == 1


def test_in_lockstep_a_peer_of_the_router_becomes_its_client(monkeypatch: pytest.MonkeyPatch) -> None:
    from wire.session import lockstep_topology
    from wire.timemode import LOCKSTEP_ENV

    peer = NetworkConfig(namespace=NS, connect=("tcp/127.0.0.1:7447",))
    listening = NetworkConfig(namespace=NS, listen=("tcp/127.0.0.1:7448",))
    monkeypatch.delenv(LOCKSTEP_ENV, raising=False)
    assert lockstep_topology(peer).mode == "peer"  # real time: a peer asked for stays one (the flags make clients, wire.flags)
    monkeypatch.setenv(LOCKSTEP_ENV, "1")
    assert lockstep_topology(peer).mode == "client"  # every message and every barrier ask through the router, in order
    assert lockstep_topology(peer).zenoh_json()["mode"] == "client" and "listen" not in lockstep_topology(peer).zenoh_json()
    assert lockstep_topology(listening) == listening  # a process others connect to stays as it is


def test_an_executor_job_counts_until_its_result_reached_the_loop() -> None:
    """The job's count drops only after asyncio's hand-over of its result, even if the worker stalls between the two."""

    class Stalling(_CountingExecutor):
        def submit(self, fn, /, *args, **kwargs):  # noqa: ANN001, ANN202
            fut = super().submit(fn, *args, **kwargs)
            # the worker thread descheduled after the job's end, before asyncio queued the result (a loaded machine):
            # modelled as a 20 ms stall in a done callback that runs before asyncio's own (it registers after submit)
            fut.add_done_callback(lambda _f: threading.Event().wait(0.02))
            return fut

    handed_over: list[bool] = []

    async def main() -> None:
        loop = asyncio.get_running_loop()
        ex = Stalling(loop)
        loop.set_default_executor(ex)
        jobs: list[asyncio.Future] = []
        count_drop = ex._dec

        def dec() -> None:  # the k-th drop belongs to the k-th job
            count_drop()
            loop.call_soon(look, jobs.pop(0))

        def look(job: asyncio.Future) -> None:  # a participant's next check: the job's coroutine must be able to go on
            handed_over.append(job.done() or bool(loop._ready))  # type: ignore[attr-defined]

        ex._dec = dec  # type: ignore[method-assign]
        for i in range(5):
            fut = loop.run_in_executor(None, sum, (i, 1))
            jobs.append(fut)
            assert await fut == i + 1
        ex.shutdown()

    asyncio.run(main())
    assert handed_over == [True] * 5
