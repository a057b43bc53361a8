"""Start, monitor and control the modules a system configuration names (EDDIE's module management).

Each local module runs as its own process (`python -m <run> <args> --ns … --connect …`); the supervisor
waits for its READY line, follows every module's heartbeat and liveliness token, and reports each one
as `starting`, `ready`, `wedged` (token alive, heartbeat silent) or `dead` (process gone or token gone).
`restart(name)` stops and starts one module. Modules on other hosts are only watched.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Literal

from runtime.lifecycle import READY_PREFIX
from wire.aio import Link
from wire.health import Heartbeat, HeartbeatError, decode_heartbeat
from wire.keys import ModuleKeys
from wire.lifeline import die_with_parent
from wire.network import NetworkConfig

from eddie.errors import SupervisorError
from eddie.toolkit.system_config import ModuleSpec, SystemConfig
from wire.ratelimit import warn_limited

__all__ = ["Supervisor", "ModuleHealth", "ModuleStatus"]

log = logging.getLogger(__name__)

#: What the supervisor says about a module.
ModuleHealth = Literal["starting", "ready", "wedged", "dead"]


@dataclass(frozen=True)
class ModuleStatus:
    """One module's state: health, pid (None if not started here), heartbeat age [s wall], restarts, exit code."""

    name: str
    health: ModuleHealth
    pid: int | None
    heartbeat_age_s: float | None
    restarts: int
    returncode: int | None


@dataclass
class _Child:
    spec: ModuleSpec
    proc: asyncio.subprocess.Process | None = None
    ready: asyncio.Event = field(default_factory=asyncio.Event)
    restarts: int = 0
    last_beat: float | None = None
    period_s: float = 1.0
    alive_token: bool = False
    reader: asyncio.Task[None] | None = None


class Supervisor:
    """Run the modules of `config` on network `net`, writing each module's output to `log_dir/<name>.log`.

    The modules connect to `connect` (default: the endpoints `net` connects to).
    """

    def __init__(self, config: SystemConfig, net: NetworkConfig, log_dir: str | Path, *, wedged_after: float = 3.0,
                 env: dict[str, str] | None = None, connect: tuple[str, ...] | None = None) -> None:
        self.config = config
        self.net = net
        self.log_dir = Path(log_dir)
        self.wedged_after = wedged_after
        self.keys = ModuleKeys(net.namespace)
        self._env = env or {}
        #: endpoints the modules connect to (default: the supervisor's own)
        self.connect = connect if connect is not None else tuple(net.connect)
        self._children = {m.name: _Child(m) for m in config.modules}
        self._link: Link | None = None
        self._changed = asyncio.Event()

    async def __aenter__(self) -> "Supervisor":
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self._link = Link.open(self.net)
        self._link.subscribe(self.keys.heartbeat_all, self._on_heartbeat)
        self._link.watch_alive(self.keys.alive_all, self._on_alive, history=True)
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.stop_all()
        if self._link is not None:
            self._link.close()

    # ---- control -------------------------------------------------------------------------

    def _net_args(self) -> list[str]:
        args = ["--ns", self.net.namespace]
        for e in self.connect:
            args += ["--connect", e]
        return args

    async def start(self, name: str) -> None:
        """Start module `name` (if local and not running); raise SupervisorError for an unknown or remote one."""
        child = self._child(name)
        if not child.spec.local:
            raise SupervisorError(f"module {name!r} runs on host {child.spec.host!r}: start it there (`sidewalk up`)")
        if child.proc is not None and child.proc.returncode is None:
            return
        argv = [sys.executable, *self.config.argv(name), *self._net_args()]
        env = {**os.environ, **self._env, **child.spec.env, "PYTHONUNBUFFERED": "1"}
        out = open(self.log_dir / f"{name}.log", "ab")  # noqa: SIM115 - handed to the child
        try:
            child.proc = await asyncio.create_subprocess_exec(*argv, stdout=asyncio.subprocess.PIPE, stderr=out, env=env,
                                                              preexec_fn=die_with_parent())  # a killed supervisor takes them along
        except OSError as exc:
            raise SupervisorError(f"module {name!r}: cannot start {argv[1:]}: {exc}") from None
        finally:
            out.close()
        child.ready = asyncio.Event()
        child.last_beat = None
        child.reader = asyncio.get_running_loop().create_task(self._read_stdout(child))
        log.info("started %s (pid %d)", name, child.proc.pid)

    async def start_all(self, timeout: float = 30.0) -> None:
        """Start every local module and wait for each one's READY line (timeout wall [s])."""
        for m in self.config.modules:
            if m.local:
                await self.start(m.name)
        for m in self.config.modules:
            if m.local:
                await self.wait_ready(m.name, timeout)

    async def wait_ready(self, name: str, timeout: float = 30.0) -> None:
        """Wait until module `name` printed its READY line; SupervisorError if it exits or stays silent."""
        child = self._child(name)
        if child.proc is None:
            raise SupervisorError(f"module {name!r} was not started")
        waiter = asyncio.ensure_future(child.ready.wait())
        exited = asyncio.ensure_future(child.proc.wait())
        try:
            done, _ = await asyncio.wait({waiter, exited}, timeout=timeout, return_when=asyncio.FIRST_COMPLETED)
        finally:
            waiter.cancel()
            exited.cancel()
        if not child.ready.is_set():
            why = f"exited with code {child.proc.returncode}" if child.proc.returncode is not None else f"not ready within {timeout:g} s"
            raise SupervisorError(f"module {name!r} {why} (see {self.log_dir / (name + '.log')})")

    async def stop(self, name: str, timeout: float = 5.0) -> None:
        """Stop module `name` (SIGTERM, then SIGKILL after `timeout` wall [s])."""
        child = self._child(name)
        proc = child.proc
        if proc is None or proc.returncode is not None:
            return
        with contextlib.suppress(ProcessLookupError):
            proc.terminate()
        try:
            await asyncio.wait_for(proc.wait(), timeout)
        except asyncio.TimeoutError:
            with contextlib.suppress(ProcessLookupError):
                proc.kill()
            await proc.wait()
        if child.reader is not None:
            child.reader.cancel()

    async def restart(self, name: str, timeout: float = 30.0) -> None:
        """Stop and start module `name`, waiting until it is ready again."""
        await self.stop(name)
        self._child(name).restarts += 1
        await self.start(name)
        await self.wait_ready(name, timeout)

    async def stop_all(self) -> None:
        """Stop every module started here, in reverse order."""
        for m in reversed(self.config.modules):
            await self.stop(m.name)

    # ---- monitoring ----------------------------------------------------------------------

    def pid(self, name: str) -> int | None:
        """Return the pid of module `name` if it was started here."""
        proc = self._child(name).proc
        return proc.pid if proc is not None else None

    def status(self, name: str) -> ModuleStatus:
        """Return what is known of module `name` now."""
        c = self._child(name)
        age = None if c.last_beat is None else time.monotonic() - c.last_beat
        rc = c.proc.returncode if c.proc is not None else None
        health: ModuleHealth
        if (c.proc is not None and rc is not None) or (c.spec.local and c.proc is None):
            health = "dead"
        elif c.last_beat is None and not c.ready.is_set():
            health = "starting"
        elif age is not None and age > max(self.wedged_after, 3 * c.period_s):
            health = "wedged" if c.alive_token or (c.proc is not None and rc is None) else "dead"
        else:
            health = "ready"
        return ModuleStatus(name=name, health=health, pid=self.pid(name), heartbeat_age_s=age, restarts=c.restarts,
                            returncode=rc)

    def statuses(self) -> list[ModuleStatus]:
        """Return every configured module's status."""
        return [self.status(m.name) for m in self.config.modules]

    async def wait_for(self, name: str, health: ModuleHealth, timeout: float = 10.0) -> ModuleStatus:
        """Wait until module `name` reports `health` (re-checked on every heartbeat, token change or exit)."""
        return await self._wait(name, lambda st: st.health == health, timeout,
                                lambda st: f"module {name!r} is {st.health}, not {health}, after {timeout:g} s")

    async def wait_heartbeat(self, name: str, timeout: float = 10.0) -> ModuleStatus:
        """Wait until a heartbeat of module `name` has been heard (its ready line may come first); return its status."""
        return await self._wait(name, lambda st: st.heartbeat_age_s is not None, timeout,
                                lambda st: f"no heartbeat from module {name!r} within {timeout:g} s (it is {st.health})")

    async def _wait(self, name: str, done: Callable[[ModuleStatus], bool], timeout: float,
                    why: Callable[[ModuleStatus], str]) -> ModuleStatus:
        deadline = time.monotonic() + timeout
        while not done(st := self.status(name)):
            left = deadline - time.monotonic()
            if left <= 0:
                raise SupervisorError(why(st))
            self._changed.clear()
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(self._changed.wait(), min(left, 0.5))
        return st

    # ---- internals -----------------------------------------------------------------------

    def _child(self, name: str) -> _Child:
        try:
            return self._children[name]
        except KeyError:
            raise SupervisorError(f"no module named {name!r} in the system configuration") from None

    async def _read_stdout(self, child: _Child) -> None:
        proc = child.proc
        assert proc is not None and proc.stdout is not None
        with open(self.log_dir / f"{child.spec.name}.log", "ab") as out:
            while True:
                line = await proc.stdout.readline()
                if not line:
                    break
                out.write(line)
                out.flush()
                if line.decode("utf-8", "replace").startswith(f"{READY_PREFIX} {child.spec.name}"):
                    child.ready.set()
        await proc.wait()
        log.warning("module %s exited with code %s", child.spec.name, proc.returncode)
        self._changed.set()

    def _on_heartbeat(self, key: str, payload: bytes) -> None:
        name = key.rsplit("/", 1)[-1]
        child = self._children.get(name)
        if child is None:
            return
        try:
            hb: Heartbeat = decode_heartbeat(payload)
        except HeartbeatError as exc:
            warn_limited(log, "bad-heartbeat", "bad heartbeat on %s: %.200s", key, exc)
            return
        child.period_s = hb.period_s
        child.last_beat = None if hb.state == "stopping" else time.monotonic()
        self._changed.set()

    def _on_alive(self, key: str, alive: bool) -> None:
        child = self._children.get(key.rsplit("/", 1)[-1])
        if child is not None:
            child.alive_token = alive
            self._changed.set()
