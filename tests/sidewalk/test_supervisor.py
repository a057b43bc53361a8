"""The supervisor starts real processes, waits for readiness, sees crashes and stops cleanly."""

import asyncio
import signal
import sys
import time

import pytest

from sidewalk.supervisor import ProcessPlan, ProcessStartError, Supervisor

# A child that prints its ready line and then waits for a signal; on SIGINT it exits 0.
SERVER = (
    "import signal, sys, threading\n"
    "done = threading.Event()\n"
    "signal.signal(signal.SIGINT, lambda *a: done.set())\n"
    "print('booting', flush=True)\n"
    "print('SIDEWALK-READY child', flush=True)\n"
    "done.wait()\n"
    "sys.exit(0)\n"
)
# A child that ignores SIGINT and SIGTERM: only SIGKILL ends it.
STUBBORN = (
    "import signal, threading\n"
    "signal.signal(signal.SIGINT, signal.SIG_IGN)\n"
    "signal.signal(signal.SIGTERM, signal.SIG_IGN)\n"
    "print('ready', flush=True)\n"
    "threading.Event().wait()\n"
)


async def test_start_waits_for_ready_and_stop_is_graceful(tmp_path):
    sup = Supervisor(tmp_path)
    mp = await sup.start(ProcessPlan("child", ("-c", SERVER)), ready_timeout=30)
    assert sup.alive("child")
    codes = await sup.stop_all(grace=10)
    assert codes == {"child": 0}
    log = (tmp_path / "child.log").read_text()
    assert "booting" in log and "SIDEWALK-READY" in log
    assert mp.cpu_s >= 0.0


async def test_a_process_that_dies_before_ready_is_an_error_with_its_log(tmp_path):
    sup = Supervisor(tmp_path)
    with pytest.raises(ProcessStartError, match="exited with code 3") as exc:
        await sup.start(ProcessPlan("bad", ("-c", "import sys; sys.stderr.write('no world file\\n'); sys.exit(3)")), ready_timeout=30)
    assert "no world file" in str(exc.value)
    await sup.stop_all()


async def test_a_silent_process_times_out_and_is_stopped(tmp_path):
    sup = Supervisor(tmp_path)
    with pytest.raises(ProcessStartError, match="no ready line"):
        await sup.start(ProcessPlan("mute", ("-c", "import time; time.sleep(60)")), ready_timeout=1.0)
    assert not sup.alive("mute")
    await sup.stop_all()


async def test_a_killed_process_is_reported_and_the_others_stay_up(tmp_path):
    sup = Supervisor(tmp_path)
    await sup.start(ProcessPlan("a", ("-c", SERVER)), ready_timeout=30)
    await sup.start(ProcessPlan("b", ("-c", SERVER)), ready_timeout=30)
    await sup.kill("a", signal.SIGKILL)
    dead = await asyncio.wait_for(sup.crashed.get(), 10)
    assert dead.plan.name == "a" and dead.proc.returncode == -signal.SIGKILL
    assert sup.alive("b") and not sup.alive("a")
    codes = await sup.stop_all(grace=10)
    assert codes["b"] == 0
    assert sup.crashed.empty()  # an expected stop is not a crash


async def test_stop_escalates_to_sigkill(tmp_path):
    sup = Supervisor(tmp_path)
    await sup.start(ProcessPlan("stubborn", ("-c", STUBBORN)), ready_timeout=30)
    codes = await sup.stop_all(grace=0.5)
    assert codes["stubborn"] == -signal.SIGKILL


# A stubborn child stuck in a function of its own that prints its stacks on request, as every process of a run does.
STUCK = (
    "import signal, threading\n"
    "from wire.lifeline import dump_stacks_on_request\n"
    "signal.signal(signal.SIGINT, signal.SIG_IGN)\n"
    "signal.signal(signal.SIGTERM, signal.SIG_IGN)\n"
    "dump_stacks_on_request()\n"
    "def closing_a_session_that_never_closes():\n"
    "    threading.Event().wait()\n"
    "print('ready', flush=True)\n"
    "closing_a_session_that_never_closes()\n"
)


async def test_a_process_that_does_not_stop_says_where_it_is_stuck_before_it_is_killed(tmp_path):
    sup = Supervisor(tmp_path)
    await sup.start(ProcessPlan("stuck", ("-c", STUCK)), ready_timeout=30)
    codes = await sup.stop_all(grace=0.5)
    assert codes["stuck"] == -signal.SIGKILL  # the stack dump did not end it (SIGUSR1 uncaught would have: -10)
    log = (tmp_path / "stuck.log").read_text()
    assert "closing_a_session_that_never_closes" in log and "Current thread" in log


def _notices(sup: Supervisor) -> tuple[list[str], asyncio.Event]:
    """Collect the supervisor's notices; the event is set once it gave up on a process."""
    notices: list[str] = []
    gave = asyncio.Event()

    def note(text: str) -> None:
        notices.append(text)
        if "gave up" in text:
            gave.set()

    sup.on_notice = note
    return notices, gave


# A child that says it is ready and exits at once: a crash loop.
CRASHER = "import sys; print('ready', flush=True); sys.exit(7)"


async def test_a_crash_looping_process_is_backed_off_reported_and_given_up_without_spinning(tmp_path):
    import resource
    import time

    from sidewalk.supervisor import RestartPolicy

    sup = Supervisor(tmp_path)
    notices, gave = _notices(sup)
    await sup.start(ProcessPlan("looper", ("-c", CRASHER)), ready_timeout=30)
    policy = RestartPolicy(backoff_s=0.2, backoff_max_s=1.0, give_up_after=5)
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.monotonic()
    sup.guard(["looper"], policy)
    try:
        await asyncio.wait_for(gave.wait(), 60)
        wall = time.monotonic() - t0
        cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    finally:
        await sup.stop_all(grace=5)
    # five restarts, each after a longer wait (0.2, 0.4, 0.8, then capped at 1.0), then it gave up
    assert [r.delay_s for r in sup.restarts] == [0.2, 0.4, 0.8, 1.0, 1.0]
    assert all(r.reason == "exited with code 7" and r.module == "looper" for r in sup.restarts)
    starts = [r.at_s for r in sup.restarts]
    assert all(b - a >= d for a, b, d in zip(starts, starts[1:], [0.4, 0.8, 1.0, 1.0])), starts
    assert len(sup.gave_up) == 1 and sup.gave_up[0].failures == 5 and "code 7" in sup.gave_up[0].reason
    assert any("gave up" in n for n in notices) and any("restarting it in 0.2 s" in n for n in notices)
    assert not sup.alive("looper")
    # the supervisor waited, it did not spin: its own CPU is a small part of the wall time the loop took
    cpu = (cpu1.ru_utime + cpu1.ru_stime) - (cpu0.ru_utime + cpu0.ru_stime)
    assert cpu < 0.25 * wall, (cpu, wall)


async def test_a_process_killed_by_its_owner_is_left_to_the_owner(tmp_path):
    from sidewalk.supervisor import RestartPolicy

    sup = Supervisor(tmp_path)
    await sup.start(ProcessPlan("a", ("-c", SERVER)), ready_timeout=30)
    sup.guard(["a"], RestartPolicy(backoff_s=0.05))
    await sup.kill("a", signal.SIGKILL)  # fault injection: the caller restarts it
    assert (await asyncio.wait_for(sup.crashed.get(), 10)).plan.name == "a"
    # a guarded process that dies on its own is restarted; the one killed by its owner is not
    await sup.start(ProcessPlan("b", ("-c", CRASHER)), ready_timeout=30)
    _, gave = _notices(sup)
    sup.guard(["b"], RestartPolicy(backoff_s=0.05, give_up_after=1))
    await asyncio.wait_for(gave.wait(), 30)
    try:
        assert {r.module for r in sup.restarts} == {"b"}
        assert not sup.alive("a")
        await sup.start(ProcessPlan("a", ("-c", SERVER)), ready_timeout=30)
        assert sup.alive("a")
    finally:
        codes = await sup.stop_all(grace=5)
    assert codes["a"] == 0


async def test_a_ready_life_never_heard_beating_is_reported_wedged_from_when_the_watch_began(tmp_path):
    # the heartbeats it might have sent before the watch began were never heard: it is judged from then
    from sidewalk.supervisor import RestartPolicy

    sup = Supervisor(tmp_path)
    heard: dict[str, tuple[int, float]] = {}
    mp = await sup.start(ProcessPlan("mute", ("-c", SERVER)), ready_timeout=30)
    await sup.start(ProcessPlan("beating", ("-c", SERVER)), ready_timeout=30)
    wedged = asyncio.Event()
    sup.on_notice = lambda text: wedged.set() if "wedged" in text else None
    loop = asyncio.get_running_loop()

    def beat() -> None:  # "beating" beats at 4 Hz (its pid, now), "mute" never
        heard["beating"] = (sup.procs["beating"].pid, time.monotonic())
        handle[0] = loop.call_later(0.25, beat)

    handle = [loop.call_later(0.0, beat)]
    t0 = time.monotonic()
    sup.guard(["mute", "beating"], RestartPolicy(wedged_after_s=1.0, restart_wedged_after_s=None), beats=heard.get)
    try:
        await asyncio.wait_for(wedged.wait(), 10)
        (w,) = sup.wedges
        assert w.module == "mute" and w.pid == mp.pid and 1.0 <= w.silent_s < 1.5
        assert sup.t0 + w.at_s - t0 < 1.5
    finally:
        handle[0].cancel()
        await sup.stop_all(grace=10)


async def test_a_process_its_owner_stopped_is_not_restarted_for_its_silence_until_the_owner_continues_it(tmp_path):
    # the wedge faults stop a module for 5 s sim: in lock-step on a busy machine that outlasts the 10 s wall watch
    from sidewalk.supervisor import RestartPolicy

    sup = Supervisor(tmp_path)
    held = await sup.start(ProcessPlan("held", ("-c", SERVER)), ready_timeout=30)
    other = await sup.start(ProcessPlan("other", ("-c", SERVER)), ready_timeout=30)
    notices: list[str] = []
    restarted = {name: asyncio.Event() for name in ("held", "other")}

    def note(text: str) -> None:
        notices.append(text)
        for name, event in restarted.items():
            if text.startswith(f"{name} restarted"):
                event.set()

    sup.on_notice = note
    heard: dict[str, tuple[int, float]] = {}  # neither beats: both are judged from when the watch began
    sup.guard(["held", "other"], RestartPolicy(wedged_after_s=0.5, restart_wedged_after_s=1.5, backoff_s=0.05),
              beats=heard.get)
    sup.suspend("held")
    other.proc.send_signal(signal.SIGSTOP)  # stopped behind the supervisor's back: restarted once silent for 1.5 s
    try:
        await asyncio.wait_for(restarted["other"].wait(), 30)
        assert sup.procs["held"].pid == held.pid and sup.alive("held"), notices
        assert any(n.startswith("held is wedged") for n in notices), notices  # reported all the same
        resumed = time.monotonic()
        sup.resume("held")
        # still silent once continued (nothing beats here): restarted, its silence judged from the resume
        await asyncio.wait_for(restarted["held"].wait(), 30)
        (r,) = [r for r in sup.restarts if r.module == "held"]
        assert sup.t0 + r.at_s - resumed >= 1.5, (r, resumed)
    finally:
        await sup.stop_all(grace=10)
