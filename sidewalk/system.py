"""A running Sidewalk system: its processes, a session to it, the recorder and the mission status."""

from __future__ import annotations

import asyncio
import logging
import time
from pathlib import Path
from typing import Callable, Optional

from pydantic import ValidationError

from blackboard import BlackboardClient, BlackboardError, MonitorStream, NetworkConfig, Spec
from blackboard.codec import decode
from blackboard.replies import NodeStats
from sidewalk.mission_client import MissionClient, MissionServiceUnavailable
from runtime import ModuleKeys, Link
from wire.keys import BlackboardKeys, SimKeys
from wire.lockstep import LockstepRelease, NotReleasedError, decode as decode_lockstep
from wire.network import SecureConfig
from modules.vocabulary import MissionStatus, RoutePlan
from sidewalk.recorder import Recorder
from sidewalk.run_record import RecordedPlan, StampedStatus
from sidewalk.health import BeatLog
from sidewalk.supervisor import READY_TIMEOUT_S, ProcessPlan, RestartPolicy, Supervisor

log = logging.getLogger(__name__)

__all__ = ["SystemRun", "UNGUARDED"]

#: Processes the supervisor does not restart: the router (every session hangs on it), the simulator
#: (a new one would put the vehicle back at its start: truth lost) and the observers of the run.
UNGUARDED = frozenset({"router", "sim", "recorder", "monitor"})


class SystemRun:
    """Start the planned processes in order, then watch the system from outside like an operator.

    `start()` waits for every process's ready line, then opens a Zenoh session and a blackboard
    client, starts the recorder (truth, events, clock, estimates, heartbeats) and monitors mission
    status tokens. It keeps what a run record needs: when each mission was accepted and every status
    received, stamped with wall [s] since construction and the sim clock [s] then; `snapshot()`
    waits for the vehicle to come to rest and fetches the route plans and the node's counters before `close()`.
    `close()` stops everything in reverse order (still listening, so the processes' last heartbeats
    reach the recorder) and returns the exit code of each process.
    """

    def __init__(self, plans: list[ProcessPlan], *, ns: str, endpoint: str, log_dir: Path, secure: Path | None = None,
                 lockstep: bool = False) -> None:
        self.plans = {p.name: p for p in plans}
        self.ns = ns
        #: the simulator steps in lock-step: the recorder samples the estimate on a fixed grid of sim time
        self.lockstep = lockstep
        # a client of the router as every process of the system (wire.flags); under --secure the observer is
        # `evaluation` (it reads truth) and submits as the `operator`
        self.net = NetworkConfig(namespace=ns, mode="client", connect=(endpoint,),
                                 secure=None if secure is None else SecureConfig(dir=secure, role="evaluation"))
        self._operator: Link | None = None
        self.sup = Supervisor(log_dir)
        self.link: Link | None = None
        self.bb: BlackboardClient | None = None
        self.recorder: Recorder | None = None
        self._status: MonitorStream | None = None
        self._crashed_seen: list[str] = []
        self._beats: BeatLog | None = None
        self.t0 = time.monotonic()
        #: mission id → (wall [s] since construction, sim [s]) when the CAPTAIN accepted it
        self.submitted: dict[str, tuple[float, float]] = {}
        #: mission id → every status received, in order
        self.statuses: dict[str, list[StampedStatus]] = {}
        #: mission id → its route plans, and the blackboard's counters, as fetched by `finish()`
        self.routes: dict[str, list[RecordedPlan]] = {}
        #: mission id → when [s] sim the vehicle came to rest after it ended (None: it did not), by `finish()`
        self.rest: dict[str, float | None] = {}
        self.bb_stats: dict | None = None

    async def start(self, *, on_starting: Callable[[str], None] | None = None, ready_timeout: float = READY_TIMEOUT_S) -> None:
        """Start every process, then connect the observer side: the recorder (`_recorder`) and the mission follower (`_follow`)."""
        for plan in self.plans.values():
            if on_starting:
                on_starting(plan.name)
            await self.sup.start(plan, ready_timeout=ready_timeout)
        self.link = Link.open(self.net)
        # heard from the first moment: a module stopped right after `guard()` has beaten into it already
        self._beats = BeatLog(self.link, ModuleKeys(self.ns))
        self.recorder = await self._recorder()
        self.recorder.start()
        await self.recorder.wait_clock()
        # every process's first heartbeat heard, so a fault injected at once still counts the first life's cost
        missing = await self.recorder.wait_usage(set(self.plans) - {"recorder", "monitor"}, timeout=5.0)
        if missing:
            log.warning("no heartbeat with usage yet from %s: their costs may miss this life", ", ".join(sorted(missing)))
        await self._follow()

    async def _recorder(self) -> Recorder:
        """Return the run's recorder: CODGER's estimate is the PILOT's, read through a blackboard client."""
        self.bb = await BlackboardClient.connect(self.net, source="launcher")
        return Recorder(self.link, self.bb, self.ns, lockstep=self.lockstep)

    async def _follow(self) -> None:
        """Follow the missions' statuses: CODGER's on the blackboard (`mission_status` tokens)."""
        self._status = self.bb.monitor(Spec(type="mission_status"))
        await self._status.start()

    async def submit(self, text: str, *, timeout: float = 15.0) -> str:
        """Submit a mission to the CAPTAIN as `sidewalk submit` does; return its id."""
        assert self.link is not None
        if self.net.secure is not None and self._operator is None:
            self._operator = Link.open(self.net.with_role("operator"))
        link = self._operator or self.link
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while True:
            # Right after the CAPTAIN says it is ready, its queryable may not have reached this
            # session yet: a query nobody answers returns at once, so ask again until the timeout.
            left = end - loop.time()
            try:
                accepted = await MissionClient(link, ModuleKeys(self.ns), timeout=max(left, 0.5)).submit(text)
                self.submitted[accepted.mission_id] = self.stamps()
                return accepted.mission_id
            except MissionServiceUnavailable:
                if loop.time() + 0.2 >= end:
                    raise
                await asyncio.sleep(0.2)

    async def release_lockstep(self, *, timeout: float = 10.0) -> LockstepRelease:
        """Let a lock-step simulator held at its start step on; return its answer (sim time [s sim], whether it was held).

        Raise NotReleasedError when the simulator does not answer within `timeout` [s wall], LockstepPayloadError
        when it answers badly.
        """
        assert self.link is not None
        replies = await self.link.get(SimKeys(self.ns).lockstep_release, timeout=timeout)
        ok = [r for r in replies if r.ok]
        if not ok:
            raise NotReleasedError(f"the simulator did not answer {SimKeys(self.ns).lockstep_release} "
                                       "(is it running with --lockstep?)")
        return decode_lockstep(LockstepRelease, ok[0].payload, as_json=ok[0].is_json)

    def guard(self, policy: RestartPolicy = RestartPolicy()) -> None:
        """Have the supervisor keep every process but `UNGUARDED` running: crashed ones restarted, wedged ones reported and restarted.

        Call after `start()`: the guard hears heartbeats through the observer's session.
        """
        assert self.link is not None, "guard() needs start() first"
        if self._beats is None:
            self._beats = BeatLog(self.link, ModuleKeys(self.ns))
        self.sup.guard([n for n in self.plans if n not in UNGUARDED], policy, beats=self._beats.newest)

    def stamps(self) -> tuple[float, float]:
        """Return (wall [s] since construction, newest sim time heard [s])."""
        return time.monotonic() - self.t0, self.recorder.sim_time if self.recorder is not None else 0.0

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
            if isinstance(st, MissionStatus):
                wall, sim = self.stamps()
                self.statuses.setdefault(st.mission_id, []).append(StampedStatus(wall_s=wall, sim_s=sim, status=st))
                if st.mission_id == mission_id:
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

    async def restart(self, name: str, *, ready_timeout: float = READY_TIMEOUT_S) -> None:
        """Start a process again with its original plan and wait for its ready line."""
        await self.sup.start(self.plans[name], ready_timeout=ready_timeout)

    async def route_plans(self, mission_id: str) -> list[RecordedPlan]:
        """Return every route plan of the mission (each revision of each step), polylines in `world` [m]."""
        assert self.bb is not None
        out = []
        for tok in await self.bb.retrieve(Spec(type="route_plan")):
            rp = tok.attrs
            if isinstance(rp, RoutePlan) and rp.mission_id == mission_id:
                out.append(RecordedPlan(step_index=rp.step_index, revision=rp.revision, stamp=tok.stamp, polyline=rp.polyline))
        return sorted(out, key=lambda p: (p.step_index, p.revision))

    async def finish(self, mission_id: str) -> None:
        """Wait until the vehicle has come to rest, then fetch the mission's route plans and the blackboard's counters.

        Call it once the mission ended (or was given up), before `close()`.
        """
        await self._settle(mission_id)
        self.routes[mission_id] = await self.route_plans(mission_id)
        stats = await self.blackboard_stats()
        self.bb_stats = stats.model_dump() if stats is not None else None

    async def _settle(self, mission_id: str) -> None:
        """Wait until the vehicle has come to rest, then until the record's window has been heard to its end."""
        assert self.recorder is not None
        self.rest[mission_id] = rest = await self.recorder.wait_rest()
        terminal = next((s.status for s in self.statuses.get(mission_id, []) if s.status.terminal), None)
        await self.recorder.hear_window(rest, terminal.finished_at if terminal is not None else None)

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

    async def close(self) -> dict[str, Optional[int]]:
        """Stop observing the blackboard, stop every process, then close the session; return exit codes by process name."""
        if self._status is not None:
            await self._status.close()
        if self.recorder is not None:
            await self.recorder.close()
        if self.bb is not None:
            await self.bb.close()
        try:
            codes = await self.sup.stop_all()
        finally:
            if self._beats is not None:
                self._beats.close()
            if self._operator is not None:
                self._operator.close()
            if self.link is not None:
                self.link.close()
        return codes
