"""Start Sidewalk processes as separate OS processes, wait for readiness, keep them running, stop them cleanly.

Keeping them running (`guard`): a guarded process that exits unexpectedly is started again with
the same plan; one that stays alive but whose heartbeat went silent is reported **wedged** once
silent for `RestartPolicy.wedged_after_s` (3 s wall, as `sidewalk status` judges it) and, if still
silent at `restart_wedged_after_s` (10 s wall), SIGKILLed and started again. The wedge watch runs on
a thread of its own and the heartbeats' arrivals are stamped on Zenoh's thread, so a report comes
3 s after the last beat however busy the event loop is (a run's observer decodes hundreds of
samples a second; on a loaded machine its loop falls seconds behind). The report comes at 3 s
but the kill waits longer, so a short stall (a GC pause, a loaded machine, the comparison's 5 s
`wedge` fault) comes back on its own and keeps its state. Restarts back off exponentially per
process (0.5 s, 1, 2, 4 … capped at 30 s; the count starts again once a life lasted `stable_s`),
and after `give_up_after` failed lives in a row the supervisor gives up on that process and says so.
A process the owner killed on purpose (`kill`, fault injection) is left to the owner until it
starts it again; one the owner stopped on purpose (`suspend`, the `wedge-*` faults) is reported wedged but
not restarted for its silence until the owner `resume`s it, and its silence is judged again from then:
a stop lasts as long as its owner says (5 s sim in lock-step can be tens of seconds of wall on a busy
machine), not as long as the wall clock allows.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import re
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import psutil
from pydantic import BaseModel, ConfigDict, Field

from sidewalk.errors import SidewalkError
from sidewalk.health import WEDGED_AFTER_S
from wire.lifeline import STACKS_SIGNAL, catches, die_with_parent

__all__ = ["ProcessPlan", "ManagedProcess", "Supervisor", "ProcessStartError", "READY_RE", "READY_TIMEOUT_S",
           "RestartPolicy", "Restart", "WedgeReport", "GiveUp", "BeatSource"]

#: how long [s wall] a starting process may take to say it is ready: a process that dies is noticed at once, so
#: this bounds only a slow start (the simulator took 121 s on this 2-core machine at a load of 30, numba and all)
READY_TIMEOUT_S = 300.0

log = logging.getLogger(__name__)

#: (pid, wall time.monotonic() [s]) of the newest heartbeat heard from a process, by name (None: none heard).
BeatSource = Callable[[str], Optional[tuple[int, float]]]

#: A process is ready once it prints a line matching this on stdout.
READY_RE = re.compile(r"\bready\b", re.IGNORECASE)


class ProcessStartError(SidewalkError, RuntimeError):
    """A process exited or stayed silent before printing its ready line."""


@dataclass(frozen=True)
class ProcessPlan:
    """What to start: a name, the argv after the Python interpreter, extra environment."""

    name: str
    args: tuple[str, ...]
    env: tuple[tuple[str, str], ...] = ()


class RestartPolicy(BaseModel):
    """How the supervisor keeps guarded processes running; times are wall [s]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    #: a live process silent this long is reported wedged
    wedged_after_s: float = Field(default=WEDGED_AFTER_S, gt=0.0)
    #: a live process silent this long is SIGKILLed and started again (None: only reported)
    restart_wedged_after_s: Optional[float] = Field(default=10.0, gt=0.0)
    #: the first restart's delay, doubled for each failure in a row up to `backoff_max_s`
    backoff_s: float = Field(default=0.5, gt=0.0)
    backoff_max_s: float = Field(default=30.0, gt=0.0)
    #: a life this long ends the run of failures: the next restart waits `backoff_s` again
    stable_s: float = Field(default=30.0, gt=0.0)
    #: failed lives in a row after which the supervisor gives up on the process (None: never)
    give_up_after: Optional[int] = Field(default=8, ge=1)
    ready_timeout_s: float = Field(default=READY_TIMEOUT_S, gt=0.0)

    def delay(self, failures: int) -> float:
        """Return the back-off [s] before the restart that follows `failures` (≥ 1) failed lives in a row."""
        return min(self.backoff_max_s, self.backoff_s * 2.0 ** (max(1, failures) - 1))


class Restart(BaseModel):
    """One restart by the supervisor: which process, when [s wall since the supervisor started], why, after what delay [s]."""

    model_config = ConfigDict(frozen=True)

    module: str
    at_s: float
    reason: str
    delay_s: float
    #: whether the new life printed its ready line
    ready: bool
    pid: Optional[int] = None


class WedgeReport(BaseModel):
    """A live process whose heartbeat went silent: when it was reported [s wall since start], silent how long [s]."""

    model_config = ConfigDict(frozen=True)

    module: str
    at_s: float
    silent_s: float
    pid: int


class GiveUp(BaseModel):
    """The supervisor stopped restarting a process: when [s wall since start], after how many failed lives, the last reason."""

    model_config = ConfigDict(frozen=True)

    module: str
    at_s: float
    failures: int
    reason: str


@dataclass
class _Guard:
    """What the supervisor remembers about a guarded process across its lives."""

    failures: int = 0
    reviving: Optional[asyncio.Task] = None
    wedge_reported_pid: Optional[int] = None
    gave_up: bool = False


@dataclass
class ManagedProcess:
    """A running child process and what was learnt about it."""

    plan: ProcessPlan
    proc: asyncio.subprocess.Process
    log_path: Path
    cpu_s: float = 0.0
    exited: asyncio.Event = field(default_factory=asyncio.Event)
    expected_exit: bool = False
    #: time.monotonic() [s] when the owner last continued it (`Supervisor.resume`; None: never stopped)
    resumed_at: Optional[float] = None
    #: time.monotonic() [s] when it printed its ready line (None: not yet)
    ready_at: Optional[float] = None
    _ps: psutil.Process | None = None

    @property
    def pid(self) -> int:
        return self.proc.pid

    def sample_cpu(self) -> float:
        """Update and return the process's user+system CPU time [s] (last value once it exited)."""
        try:
            if self._ps is None:
                self._ps = psutil.Process(self.proc.pid)
            t = self._ps.cpu_times()
            self.cpu_s = float(t.user + t.system)
        except (psutil.NoSuchProcess, psutil.ZombieProcess, psutil.AccessDenied):
            pass
        return self.cpu_s


class Supervisor:
    """Own a set of child processes: start in order, watch, stop in reverse order.

    Each child writes stderr (and stdout after its ready line) to `<log_dir>/<name>.log`.
    A child that dies unexpectedly is reported through `crashed` without stopping the others.
    """

    def __init__(self, log_dir: Path, *, python: str = sys.executable) -> None:
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.python = python
        self.procs: dict[str, ManagedProcess] = {}
        self.crashed: asyncio.Queue[ManagedProcess] = asyncio.Queue()
        self._tasks: list[asyncio.Task] = []
        self.t0 = time.monotonic()
        #: what `guard` did: restarts, wedges reported, processes given up on (in order)
        self.restarts: list[Restart] = []
        self.wedges: list[WedgeReport] = []
        self.gave_up: list[GiveUp] = []
        self._policy: RestartPolicy | None = None
        self._beats: BeatSource | None = None
        self._guard_t0 = 0.0
        self._guards: dict[str, _Guard] = {}
        self._held: set[str] = set()
        #: processes their owner stopped on purpose (`suspend`): not restarted for their silence until `resume`
        self._suspended: set[str] = set()
        self._wake = asyncio.Event()
        self._guard_task: asyncio.Task | None = None
        self._closing = False
        self._watch: threading.Thread | None = None
        self._watch_stop = threading.Event()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._sigterm_prev: object = None
        #: called with a one-line notice whenever the guard reports or restarts something
        self.on_notice: Callable[[str], None] | None = None

    async def start(self, plan: ProcessPlan, *, ready_timeout: float = READY_TIMEOUT_S) -> ManagedProcess:
        """Start one process and return once it printed its ready line [timeout in wall s]."""
        self._arm_sigterm()
        log_path = self.log_dir / f"{plan.name}.log"
        log = open(log_path, "ab", buffering=0)
        env = dict(os.environ)
        env.setdefault("PYTHONUNBUFFERED", "1")
        env.update(dict(plan.env))
        proc = await asyncio.create_subprocess_exec(
            self.python,
            *plan.args,
            stdin=asyncio.subprocess.DEVNULL,
            stdout=asyncio.subprocess.PIPE,
            stderr=log,
            env=env,
            start_new_session=True,  # Ctrl-C in the terminal reaches only the launcher
            preexec_fn=die_with_parent(),  # … and a launcher killed outright takes its children along
        )
        log.close()
        mp = ManagedProcess(plan=plan, proc=proc, log_path=log_path)
        self.procs[plan.name] = mp
        # released to the guard only now: until this line the guard would see the killed life's exit as a crash
        self._held.discard(plan.name)
        ready = asyncio.Event()
        self._tasks.append(asyncio.create_task(self._pump(mp, ready), name=f"pump-{plan.name}"))
        waiter = asyncio.create_task(ready.wait())
        exit_waiter = asyncio.create_task(mp.exited.wait())
        done, _ = await asyncio.wait({waiter, exit_waiter}, timeout=ready_timeout, return_when=asyncio.FIRST_COMPLETED)
        for t in (waiter, exit_waiter):
            t.cancel()
        if ready.is_set():
            mp.ready_at = time.monotonic()
            mp.sample_cpu()
            self._wake.set()
            return mp
        tail = self.tail(plan.name)
        if mp.exited.is_set():
            raise ProcessStartError(f"{plan.name} exited with code {proc.returncode} before it was ready:\n{tail}")
        await self.stop(plan.name)
        raise ProcessStartError(f"{plan.name} printed no ready line within {ready_timeout:.0f} s (load average {os.getloadavg()[0]:.1f}):\n{tail}")

    def _arm_sigterm(self) -> None:
        """Once, on the main thread's loop: on SIGTERM end every child's process group, then take SIGTERM as before."""
        if self._sigterm_prev is not None:
            return
        try:
            prev = signal.getsignal(signal.SIGTERM)
            asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, self._on_sigterm)
        except (NotImplementedError, RuntimeError, ValueError):  # not the main thread, or no signals here
            return
        self._sigterm_prev = signal.SIG_DFL if prev is None else prev

    def _disarm_sigterm(self) -> None:
        if self._sigterm_prev is None:
            return
        with contextlib.suppress(RuntimeError):
            asyncio.get_running_loop().remove_signal_handler(signal.SIGTERM)
        with contextlib.suppress(ValueError):
            signal.signal(signal.SIGTERM, self._sigterm_prev)  # type: ignore[arg-type]
        self._sigterm_prev = None

    def _on_sigterm(self) -> None:
        """SIGTERM to the launcher: SIGTERM each child's process group (own sessions: no terminal reaches them), then die of it."""
        self._closing = True
        self._watch_stop.set()
        for mp in self.procs.values():
            if not mp.exited.is_set():
                mp.expected_exit = True
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(mp.pid, signal.SIGTERM)
        self._disarm_sigterm()
        os.kill(os.getpid(), signal.SIGTERM)  # what SIGTERM would have done here without us

    async def _pump(self, mp: ManagedProcess, ready: asyncio.Event) -> None:
        assert mp.proc.stdout is not None
        with open(mp.log_path, "ab", buffering=0) as log:
            while True:
                line = await mp.proc.stdout.readline()
                if not line:
                    break
                log.write(line)
                if not ready.is_set() and READY_RE.search(line.decode(errors="replace")):
                    ready.set()
        await mp.proc.wait()
        mp.exited.set()
        self._wake.set()
        if not mp.expected_exit:
            await self.crashed.put(mp)

    def tail(self, name: str, lines: int = 15) -> str:
        """Return the last lines of a process's log."""
        try:
            text = self.procs[name].log_path.read_text(errors="replace")
        except (KeyError, OSError):
            return ""
        return "\n".join("    " + ln for ln in text.splitlines()[-lines:])

    def sample_cpu(self) -> dict[str, float]:
        """Return CPU seconds per process [s], sampled now for the live ones."""
        return {name: mp.sample_cpu() for name, mp in self.procs.items()}

    def alive(self, name: str) -> bool:
        mp = self.procs.get(name)
        return mp is not None and not mp.exited.is_set()

    async def kill(self, name: str, sig: int = signal.SIGKILL) -> None:
        """Send a signal to one process without marking the exit as expected (fault injection).

        The guard leaves the process to the caller until `start` runs it again.
        """
        self._held.add(name)
        g = self._guards.get(name)
        if g is not None and g.reviving is not None:
            g.reviving.cancel()
        mp = self.procs[name]
        mp.sample_cpu()
        with contextlib.suppress(ProcessLookupError):
            mp.proc.send_signal(sig)
        await mp.exited.wait()

    def suspend(self, name: str) -> None:
        """SIGSTOP one process on its owner's behalf (fault injection); the guard does not restart it for its silence.

        It is still reported wedged (it is). A process that is gone already is left as it is.
        """
        self._suspended.add(name)
        with contextlib.suppress(ProcessLookupError):
            self.procs[name].proc.send_signal(signal.SIGSTOP)

    def resume(self, name: str) -> None:
        """SIGCONT a process `suspend` stopped; its silence is judged again from now."""
        mp = self.procs[name]
        with contextlib.suppress(ProcessLookupError):
            mp.proc.send_signal(signal.SIGCONT)
        mp.resumed_at = time.monotonic()
        self._suspended.discard(name)
        self._wake.set()

    async def stop(self, name: str, *, grace: float = 8.0) -> int | None:
        """Stop one process: SIGINT, then SIGTERM, then SIGKILL; return its exit code.

        Before each signal after SIGINT, a process that catches `STACKS_SIGNAL` is sent it: a process stuck at
        its exit prints where each of its threads is into its log.
        """
        mp = self.procs.get(name)
        if mp is None:
            return None
        mp.expected_exit = True
        mp.sample_cpu()
        for sig, wait in ((signal.SIGINT, grace), (signal.SIGTERM, grace / 2), (signal.SIGKILL, grace)):
            if mp.exited.is_set():
                break
            if sig != signal.SIGINT and catches(mp.proc.pid, STACKS_SIGNAL):  # say where it is stuck before forcing it
                log.warning("%s has not stopped since SIGINT: its threads' stacks are in its log; sending %s", name, sig.name)
                with contextlib.suppress(ProcessLookupError):
                    mp.proc.send_signal(STACKS_SIGNAL)
            with contextlib.suppress(ProcessLookupError):
                mp.proc.send_signal(sig)
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(mp.exited.wait(), wait)
        return mp.proc.returncode

    async def stop_all(self, *, grace: float = 8.0) -> dict[str, int | None]:
        """Stop guarding, then stop every process in reverse start order; return exit codes by name."""
        self._closing = True
        self._watch_stop.set()
        if self._watch is not None:
            await asyncio.to_thread(self._watch.join)
        pending = [t for t in [self._guard_task, *(g.reviving for g in self._guards.values())] if t is not None]
        for t in pending:
            t.cancel()
        await asyncio.gather(*pending, return_exceptions=True)
        codes: dict[str, int | None] = {}
        for name in reversed(list(self.procs)):
            codes[name] = await self.stop(name, grace=grace)
        for t in self._tasks:
            t.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        self._disarm_sigterm()
        return codes

    # ---- keeping processes running ------------------------------------------------------------

    def guard(self, names: list[str] | tuple[str, ...], policy: RestartPolicy = RestartPolicy(), *,
              beats: BeatSource | None = None) -> None:
        """Keep the named processes running under `policy`; `beats` tells their newest heartbeats (None: no wedge watch)."""
        self._policy = policy
        self._beats = beats
        if not self._guard_t0:
            self._guard_t0 = time.monotonic()
        for n in names:
            self._guards.setdefault(n, _Guard())
        if self._guard_task is None:
            self._loop = asyncio.get_running_loop()
            self._guard_task = asyncio.create_task(self._guard_loop(), name="supervisor-guard")
        if beats is not None and self._watch is None:
            self._watch = threading.Thread(target=self._watch_wedges, name="supervisor-wedge-watch", daemon=True)
            self._watch.start()

    def _since(self) -> float:
        return round(time.monotonic() - self.t0, 3)

    def _notice(self, text: str, *, level: int = logging.WARNING) -> None:
        log.log(level, "%s", text)
        if self.on_notice is not None:
            self.on_notice(text)

    async def _guard_loop(self) -> None:
        """Wake on every exit, start and heartbeat deadline; restart what died, report and restart what is wedged."""
        assert self._policy is not None
        pol = self._policy
        while not self._closing:
            self._wake.clear()
            now = time.monotonic()
            next_check = now + 1.0  # heartbeats arrive at 1 Hz: look again at least that often
            for name, g in self._guards.items():
                mp = self.procs.get(name)
                if mp is None or g.gave_up or name in self._held or (g.reviving is not None and not g.reviving.done()):
                    continue
                if mp.exited.is_set():
                    if not mp.expected_exit:
                        self._revive(name, g, f"exited with code {mp.proc.returncode}")
                    continue
                last = self._last_sign(mp)
                if last is None or pol.restart_wedged_after_s is None or name in self._suspended:
                    continue
                silent = now - last
                if silent >= pol.restart_wedged_after_s:
                    self._revive(name, g, f"wedged: no heartbeat for {silent:.1f} s", kill=mp)
                    continue
                next_check = min(next_check, last + pol.restart_wedged_after_s)
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(self._wake.wait(), max(0.01, next_check - time.monotonic()))

    def _watch_wedges(self) -> None:
        """On its own thread: report each guarded life silent for `wedged_after_s` once, at that moment."""
        assert self._policy is not None and self._beats is not None and self._loop is not None
        pol, loop = self._policy, self._loop
        wait = 0.0
        while not self._watch_stop.wait(wait):
            now = time.monotonic()
            due = now + 1.0  # heartbeats arrive at 1 Hz: look again at least that often
            for name, g in list(self._guards.items()):
                mp = self.procs.get(name)
                if (mp is None or g.gave_up or name in self._held or mp.ready_at is None or mp.exited.is_set()
                        or g.wedge_reported_pid == mp.pid or (g.reviving is not None and not g.reviving.done())):
                    continue
                last = self._last_sign(mp)
                if last is None:
                    continue
                silent = now - last
                if silent < pol.wedged_after_s:
                    due = min(due, last + pol.wedged_after_s)
                    continue
                g.wedge_reported_pid = mp.pid
                self.wedges.append(WedgeReport(module=name, at_s=self._since(), silent_s=round(silent, 3), pid=mp.pid))
                text = f"{name} is wedged: alive (pid {mp.pid}) but no heartbeat for {silent:.1f} s"
                with contextlib.suppress(RuntimeError):  # the loop closed: nobody left to tell
                    loop.call_soon_threadsafe(self._notice, text)
            wait = max(0.01, due - time.monotonic())

    def _last_sign(self, mp: ManagedProcess) -> float | None:
        """Return when [s, time.monotonic] this life last showed it works: its newest heartbeat, else its ready line.

        A life never heard beating is judged from when it was ready or the watch began, whichever is
        later: one stopped before its first heartbeat reached us is as wedged as one that went quiet.
        None: not ready yet, or no heartbeats to judge by.
        """
        if self._beats is None or mp.ready_at is None:
            return None
        beat = self._beats(mp.plan.name)
        last = beat[1] if beat is not None and beat[0] == mp.pid else max(mp.ready_at, self._guard_t0)
        return last if mp.resumed_at is None else max(last, mp.resumed_at)

    def _revive(self, name: str, g: _Guard, reason: str, *, kill: ManagedProcess | None = None) -> None:
        g.reviving = asyncio.create_task(self._revive_task(name, g, reason, kill), name=f"revive-{name}")
        g.reviving.add_done_callback(lambda _t: self._wake.set())

    async def _revive_task(self, name: str, g: _Guard, reason: str, kill: ManagedProcess | None) -> None:
        """Start `name` again after its back-off, until a life prints its ready line or the policy gives up."""
        assert self._policy is not None
        pol = self._policy
        if kill is not None:
            kill.expected_exit = True  # the supervisor's own kill is no crash
            with contextlib.suppress(ProcessLookupError):
                kill.proc.send_signal(signal.SIGKILL)
            await kill.exited.wait()
        last = self.procs[name]
        if last.ready_at is not None and (time.monotonic() - last.ready_at) >= pol.stable_s:
            g.failures = 0
        while True:
            g.failures += 1
            if pol.give_up_after is not None and g.failures > pol.give_up_after:
                g.gave_up = True
                self.gave_up.append(GiveUp(module=name, at_s=self._since(), failures=g.failures - 1, reason=reason))
                self._notice(f"{name} crash-looped: {g.failures - 1} lives failed in a row (last: {reason}); "
                             "the supervisor gave up on it", level=logging.ERROR)
                return
            delay = pol.delay(g.failures)
            self._notice(f"{name} {reason}: restarting it in {delay:.1f} s (failure {g.failures} in a row)")
            await asyncio.sleep(delay)  # the back-off itself: nothing to wait for but time
            if self._closing or name in self._held:
                return
            at = self._since()
            try:
                mp = await self.start(self.plans_by_name(name), ready_timeout=pol.ready_timeout_s)
            except ProcessStartError as exc:
                self.restarts.append(Restart(module=name, at_s=at, reason=reason, delay_s=delay, ready=False,
                                             pid=self.procs[name].pid))
                reason = str(exc).splitlines()[0].removeprefix(f"{name} ")
                continue
            self.restarts.append(Restart(module=name, at_s=at, reason=reason, delay_s=delay, ready=True, pid=mp.pid))
            self._notice(f"{name} restarted (pid {mp.pid})", level=logging.INFO)
            return

    def plans_by_name(self, name: str) -> ProcessPlan:
        """Return the plan the named process was last started with."""
        return self.procs[name].plan
