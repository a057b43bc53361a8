"""A running Sidewalk system: its processes, a session to it, the recorder and the mission status."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from pydantic import ValidationError

from blackboard import BlackboardClient, BlackboardError, MonitorStream, NetworkConfig, Spec
from blackboard.codec import decode
from blackboard.replies import NodeStats
from modules.captain.client import CaptainUnavailableError, MissionClient
from modules.runtime import ModuleKeys, Link
from wire.keys import BlackboardKeys
from modules.vocabulary import MissionStatus, RoutePlan
from sidewalk.recorder import Recorder
from sidewalk.supervisor import ProcessPlan, Supervisor

__all__ = ["SystemRun"]


class SystemRun:
    """Start the planned processes in order, then watch the system from outside like an operator.

    `start()` waits for every process's ready line, then opens a Zenoh session and a blackboard
    client, starts the recorder (truth, events, clock, estimates) and monitors mission status tokens.
    `close()` stops everything in reverse order and returns CPU seconds and exit codes per process.
    """

    def __init__(self, plans: list[ProcessPlan], *, ns: str, endpoint: str, log_dir: Path) -> None:
        self.plans = {p.name: p for p in plans}
        self.ns = ns
        self.net = NetworkConfig(namespace=ns, connect=(endpoint,))
        self.sup = Supervisor(log_dir)
        self.link: Link | None = None
        self.bb: BlackboardClient | None = None
        self.recorder: Recorder | None = None
        self._status: MonitorStream | None = None
        self._crashed_seen: list[str] = []

    async def start(self, *, on_starting: Callable[[str], None] | None = None, ready_timeout: float = 60.0) -> None:
        """Start every process, then connect the observer side."""
        for plan in self.plans.values():
            if on_starting:
                on_starting(plan.name)
            await self.sup.start(plan, ready_timeout=ready_timeout)
        self.link = Link.open(self.net)
        self.bb = await BlackboardClient.connect(self.net, source="launcher")
        self.recorder = Recorder(self.link, self.bb, self.ns)
        self.recorder.start()
        self._status = self.bb.monitor(Spec(type="mission_status"))
        await self._status.start()

    async def submit(self, text: str, *, timeout: float = 15.0) -> str:
        """Submit a mission to the CAPTAIN as `sidewalk submit` does; return its id."""
        assert self.link is not None
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while True:
            # Right after the CAPTAIN says it is ready, its queryable may not have reached this
            # session yet: a query nobody answers returns at once, so ask again until the timeout.
            left = end - loop.time()
            try:
                accepted = await MissionClient(self.link, ModuleKeys(self.ns), timeout=max(left, 0.5)).submit(text)
                return accepted.mission_id
            except CaptainUnavailableError:
                if loop.time() + 0.2 >= end:
                    raise
                await asyncio.sleep(0.2)

    async def next_status(self, mission_id: str, timeout: float) -> Optional[MissionStatus]:
        """Return the next status of `mission_id` posted within `timeout` wall [s], else None."""
        assert self._status is not None
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while (left := end - loop.time()) > 0:
            try:
                ev = await self._status.next(timeout=left)
            except (asyncio.TimeoutError, TimeoutError):
                return None
            st = ev.token.attrs
            if isinstance(st, MissionStatus) and st.mission_id == mission_id:
                return st
        return None

    async def wait_status(self, mission_id: str, predicate: Callable[[MissionStatus], bool], timeout: float) -> MissionStatus:
        """Return the first status of `mission_id` satisfying `predicate` within `timeout` wall [s]."""
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while (left := end - loop.time()) > 0:
            st = await self.next_status(mission_id, left)
            if st is not None and predicate(st):
                return st
        raise TimeoutError(f"no status of {mission_id} satisfied the condition within {timeout:.0f} s")

    def crashed(self) -> list[str]:
        """Return the names of processes that exited unexpectedly since the last call."""
        out = []
        while not self.sup.crashed.empty():
            out.append(self.sup.crashed.get_nowait().plan.name)
        self._crashed_seen += out
        return out

    def alive(self, name: str) -> bool:
        """Return whether the named process is running."""
        return self.sup.alive(name)

    async def kill(self, name: str) -> None:
        """SIGKILL one process (fault injection) and wait until it is gone."""
        await self.sup.kill(name)

    async def restart(self, name: str, *, ready_timeout: float = 60.0) -> None:
        """Start a process again with its original plan and wait for its ready line."""
        await self.sup.start(self.plans[name], ready_timeout=ready_timeout)

    async def route_plans(self, mission_id: str) -> list[tuple[int, int, np.ndarray]]:
        """Return (step index, revision, polyline (N,2) `world` [m]) of every route plan of the mission."""
        assert self.bb is not None
        out = []
        for tok in await self.bb.retrieve(Spec(type="route_plan")):
            rp = tok.attrs
            if isinstance(rp, RoutePlan) and rp.mission_id == mission_id:
                out.append((rp.step_index, rp.revision, np.asarray(rp.polyline, dtype=float)))
        return out

    async def blackboard_stats(self) -> NodeStats | None:
        """Return the blackboard node's counters (None if it does not answer)."""
        assert self.link is not None
        replies = await self.link.get(BlackboardKeys(self.ns).stats, timeout=5.0)
        if not replies or not replies[0].ok:
            return None
        try:
            return NodeStats.model_validate(decode(replies[0].payload, as_json=replies[0].is_json))
        except (BlackboardError, ValidationError):
            return None

    async def close(self) -> tuple[dict[str, float], dict[str, Optional[int]]]:
        """Stop observing, stop every process; return (CPU seconds, exit codes) by process name."""
        if self._status is not None:
            await self._status.close()
        if self.recorder is not None:
            await self.recorder.close()
        cpu = self.sup.sample_cpu()
        if self.bb is not None:
            await self.bb.close()
        if self.link is not None:
            self.link.close()
        codes = await self.sup.stop_all()
        return cpu, codes
