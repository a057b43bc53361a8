"""Start Sidewalk processes as separate OS processes, wait for readiness, stop them cleanly."""

from __future__ import annotations

import asyncio
import contextlib
import os
import re
import signal
import sys
from dataclasses import dataclass, field
from pathlib import Path

import psutil
from sidewalk.errors import SidewalkError

__all__ = ["ProcessPlan", "ManagedProcess", "Supervisor", "ProcessStartError", "READY_RE"]

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


@dataclass
class ManagedProcess:
    """A running child process and what was learnt about it."""

    plan: ProcessPlan
    proc: asyncio.subprocess.Process
    log_path: Path
    cpu_s: float = 0.0
    exited: asyncio.Event = field(default_factory=asyncio.Event)
    expected_exit: bool = False
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

    async def start(self, plan: ProcessPlan, *, ready_timeout: float = 60.0) -> ManagedProcess:
        """Start one process and return once it printed its ready line [timeout in wall s]."""
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
        )
        log.close()
        mp = ManagedProcess(plan=plan, proc=proc, log_path=log_path)
        self.procs[plan.name] = mp
        ready = asyncio.Event()
        self._tasks.append(asyncio.create_task(self._pump(mp, ready), name=f"pump-{plan.name}"))
        waiter = asyncio.create_task(ready.wait())
        exit_waiter = asyncio.create_task(mp.exited.wait())
        done, _ = await asyncio.wait({waiter, exit_waiter}, timeout=ready_timeout, return_when=asyncio.FIRST_COMPLETED)
        for t in (waiter, exit_waiter):
            t.cancel()
        if ready.is_set():
            mp.sample_cpu()
            return mp
        tail = self.tail(plan.name)
        if mp.exited.is_set():
            raise ProcessStartError(f"{plan.name} exited with code {proc.returncode} before it was ready:\n{tail}")
        await self.stop(plan.name)
        raise ProcessStartError(f"{plan.name} printed no ready line within {ready_timeout:.0f} s:\n{tail}")

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
        """Send a signal to one process without marking the exit as expected (fault injection)."""
        mp = self.procs[name]
        mp.sample_cpu()
        with contextlib.suppress(ProcessLookupError):
            mp.proc.send_signal(sig)
        await mp.exited.wait()

    async def stop(self, name: str, *, grace: float = 8.0) -> int | None:
        """Stop one process: SIGINT, then SIGTERM, then SIGKILL; return its exit code."""
        mp = self.procs.get(name)
        if mp is None:
            return None
        mp.expected_exit = True
        mp.sample_cpu()
        for sig, wait in ((signal.SIGINT, grace), (signal.SIGTERM, grace / 2), (signal.SIGKILL, grace)):
            if mp.exited.is_set():
                break
            with contextlib.suppress(ProcessLookupError):
                mp.proc.send_signal(sig)
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(mp.exited.wait(), wait)
        return mp.proc.returncode

    async def stop_all(self, *, grace: float = 8.0) -> dict[str, int | None]:
        """Stop every process in reverse start order; return exit codes by name."""
        codes: dict[str, int | None] = {}
        for name in reversed(list(self.procs)):
            codes[name] = await self.stop(name, grace=grace)
        for t in self._tasks:
            t.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        return codes
