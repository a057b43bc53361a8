"""The supervisor starts real processes, waits for readiness, sees crashes and stops cleanly."""

import asyncio
import signal
import sys

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
