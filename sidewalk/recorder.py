"""Record a run for its report: ground truth, simulator events, sim clock, estimated poses and every process's heartbeat."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import deque
from dataclasses import dataclass, field
from typing import Awaitable, Callable, Optional

import numpy as np

from blackboard import BlackboardClient, BlackboardError
from runtime import Link
from sidewalk.run_record import ProcessCost
from wire.drive import SimClock, SimEvent, TruthPose, WireError, decode
from wire.health import HeartbeatError, decode_heartbeat
from wire.keys import ModuleKeys, SimKeys

__all__ = ["Recorder", "Track", "EstimateSource"]

#: Where the robot believes it is at a sim stamp [s]: (x [m], y [m], yaw [rad]) in `world`, None if it cannot say.
EstimateSource = Callable[[float], Awaitable[Optional[tuple[float, float, float]]]]

log = logging.getLogger(__name__)

#: the record's window reaches this far [s sim] before the mission's submission and after its end (or rest)
RECORD_LEAD_S = 1.0
#: the estimate is looked up this long [s sim] before the truth sample that makes it due (the HELM's poses trail)
ESTIMATE_LAG_S = 0.25
#: in lock-step an estimate is looked up only once the truth was heard this far [s sim] past its due stamp: the
#: recorder is outside the barrier and may hear a truth sample before the HELM's pose of that time (or a fix
#: stamped before it) reached the blackboard, and a lookup then gets the newest pose held instead (CI: one of two
#: lock-step short hops had position error rms 0.2934 against 0.2935 m)
ESTIMATE_SETTLE_S = 2.0


@dataclass
class Track:
    """A time-stamped planar track: rows of (stamp [s], x [m], y [m], yaw [rad]) in `world`."""

    rows: list[tuple[float, float, float, float]] = field(default_factory=list)

    def add(self, stamp: float, x: float, y: float, yaw: float) -> bool:
        """Append a pose at sim time `stamp` [s]; a sample of the newest row's stamp again is not kept (return False).

        A track holds one pose per sim time: the simulator repeats its pose while sim time stands (before a
        run starts, a number of times that depends on wall time), and every repeat would weigh in the
        error summaries taken over the track.
        """
        if self.rows and self.rows[-1][0] == stamp:
            return False
        self.rows.append((stamp, x, y, yaw))
        return True

    def array(self) -> np.ndarray:
        """Return the track as an (N,4) float array."""
        return np.asarray(self.rows, dtype=float).reshape(-1, 4)


class Recorder:
    """Subscribe to the simulator's truth, events and clock and to every heartbeat; sample the estimated pose from the blackboard.

    Ground truth is read here for evaluation only; no module reads it. Of the heartbeats it keeps
    the newest usage of each process incarnation (name, pid).
    """

    def __init__(self, link: Link, bb: BlackboardClient | None, ns: str, *, estimate_period_s: float = 0.5,
                 estimator: EstimateSource | None = None, lockstep: bool = False) -> None:
        """Record in namespace `ns`; the estimate comes from `estimator` (EDDIE), else from the blackboard `bb` (CODGER).

        The estimate is sampled every `estimate_period_s` [s] sim. In real time a sample due while the
        previous one is still being looked up is skipped; with `lockstep` none is, and each is looked up
        `ESTIMATE_SETTLE_S` later, so two runs of one seed sample the same stamps and find the same poses.
        """
        self.link = link
        self.bb = bb
        self.estimator = estimator or self._blackboard_pose
        self.keys = SimKeys(ns)
        self.module_keys = ModuleKeys(ns)
        self.truth = Track()
        self.estimate = Track()
        self.events: list[SimEvent] = []
        self.clock: SimClock | None = None
        self.costs: dict[tuple[str, int], ProcessCost] = {}
        self._new_truth = asyncio.Event()
        self._new_usage = asyncio.Event()
        self.estimate_period_s = estimate_period_s
        self.bad_samples = 0
        self._last_estimate_t = -1e9
        self._estimating = False
        self._tasks: set[asyncio.Task] = set()
        self.lockstep = lockstep
        self._due: deque[float] = deque()
        self._settling: deque[float] = deque()

    def start(self) -> None:
        """Declare the subscribers."""
        self.link.subscribe(self.keys.truth, self._on_truth)
        self.link.subscribe(self.keys.events, self._on_event)
        self.link.subscribe(self.keys.clock, self._on_clock)
        self.link.subscribe(self.module_keys.heartbeat_all, self._on_heartbeat)

    @property
    def sim_time(self) -> float:
        """Return the newest sim time heard [s] (0 before the first clock message)."""
        return self.clock.stamp if self.clock else 0.0

    def distance_m(self) -> float:
        """Return the distance driven so far by the true vehicle [m]."""
        a = self.truth.array()
        if len(a) < 2:
            return 0.0
        return float(np.sum(np.hypot(np.diff(a[:, 1]), np.diff(a[:, 2]))))

    def collisions(self) -> int:
        """Return the number of collision events."""
        return sum(1 for e in self.events if e.kind == "collision")

    def off_path_s(self, end_stamp: float) -> float:
        """Return the sim time spent off the path objects [s], up to end_stamp."""
        total, since = 0.0, None
        for e in sorted(self.events, key=lambda e: e.stamp):
            if e.kind == "off-path" and since is None:
                since = e.stamp
            elif e.kind == "on-path" and since is not None:
                total += e.stamp - since
                since = None
        if since is not None:
            total += max(0.0, end_stamp - since)
        return total

    def _on_truth(self, _key: str, payload: bytes) -> None:
        try:
            t = decode(TruthPose, payload)
        except WireError:
            self.bad_samples += 1
            return
        if not self.truth.add(t.stamp, t.x, t.y, t.yaw):
            return
        self._new_truth.set()
        if t.stamp - self._last_estimate_t >= self.estimate_period_s and (self.lockstep or not self._estimating):
            self._last_estimate_t = t.stamp
            (self._settling if self.lockstep else self._due).append(t.stamp)
        while self._settling and t.stamp >= self._settling[0] + ESTIMATE_SETTLE_S:
            self._due.append(self._settling.popleft())
        if self._due and not self._estimating:
            self._estimating = True
            task = asyncio.ensure_future(self._sample_estimates())
            self._tasks.add(task)
            task.add_done_callback(self._tasks.discard)

    async def _sample_estimates(self) -> None:
        """Look up the estimate at each due stamp, in order."""
        try:
            while self._due:
                stamp = self._due.popleft()
                # a little in the past: the HELM's poses trail the simulator's truth by a publish period
                at = max(0.0, stamp - ESTIMATE_LAG_S)
                try:
                    pose = await self.estimator(at)
                except (BlackboardError, asyncio.TimeoutError, TimeoutError) as exc:
                    log.debug("no estimate at %.2f: %s", stamp, exc)
                    continue
                if pose is not None:
                    self.estimate.rows.append((at, *pose))
        finally:
            self._estimating = False

    async def _blackboard_pose(self, at: float) -> tuple[float, float, float] | None:
        """Return the blackboard's world ← vehicle pose at `at` [s] sim (CODGER)."""
        if self.bb is None:
            return None
        pose = await self.bb.lookup_pose(parent="world", child="vehicle", stamp=at)
        return pose.as_tuple()

    def _on_event(self, _key: str, payload: bytes) -> None:
        try:
            self.events.append(decode(SimEvent, payload))
        except WireError:
            self.bad_samples += 1

    def rest_since(self, still_s: float, tol_m: float = 0.01, tol_rad: float = 0.005) -> float | None:
        """Return when [s] sim the true vehicle stopped, if it has not moved (tol_m [m], tol_rad [rad]) for `still_s` [s]; else None."""
        rows = self.truth.rows
        if not rows:
            return None
        t, x, y, yaw = rows[-1]
        since = t
        for r in reversed(rows):
            if abs(r[1] - x) > tol_m or abs(r[2] - y) > tol_m or abs(r[3] - yaw) > tol_rad:
                break
            since = r[0]
        else:
            return None  # still since the first sample: not yet known to have stopped for long enough
        return since if t - since >= still_s else None

    async def wait_clock(self, timeout: float = 10.0) -> bool:
        """Wait until the simulator's clock and truth have been heard (submission is stamped by them); False on timeout [s] wall."""
        return await self._until_truth(lambda: self.clock is not None and bool(self.truth.rows), timeout)

    async def _until_truth(self, done: Callable[[], bool], timeout: float) -> bool:
        """Wait, truth sample by truth sample, until `done()`; False after `timeout` [s] wall."""
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while not done():
            if (left := end - loop.time()) <= 0:
                return False
            self._new_truth.clear()
            try:
                await asyncio.wait_for(self._new_truth.wait(), left)
            except (asyncio.TimeoutError, TimeoutError):
                return False
        return True

    async def wait_usage(self, names: set[str], timeout: float = 10.0) -> set[str]:
        """Wait until a heartbeat with usage came from each process in `names`; return those not heard within `timeout` [s] wall.

        A process killed before its first heartbeat reached the recorder would be missing from the
        report's costs (a fault injected seconds after the start loses the first life's count).
        """
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while missing := names - {n for n, _pid in self.costs}:
            if (left := end - loop.time()) <= 0:
                return missing
            self._new_usage.clear()
            try:
                await asyncio.wait_for(self._new_usage.wait(), left)
            except (asyncio.TimeoutError, TimeoutError):
                return names - {n for n, _pid in self.costs}
        return set()

    async def wait_truth(self, until: float, *, max_wall_s: float = 20.0) -> bool:
        """Wait until truth stamped `until` [s] sim or later was heard (False after `max_wall_s` [s] wall).

        The estimate is looked up at each truth sample's stamp less `ESTIMATE_LAG_S`, so a record that is to hold
        every estimate up to a time must have heard the truth that far and a little farther. The launcher stops the
        simulator a varying wall moment after the mission's end (in lock-step too, being outside the barrier):
        without this wait one lock-step run's record held an estimate sample the other's did not (session 30).
        """
        return await self._until_truth(lambda: self.sim_time >= until, max_wall_s)

    async def hear_window(self, *ends: float | None) -> bool:
        """Hear the truth (so look up the estimates) to the end of the record's window: `RECORD_LEAD_S` past the
        latest of `ends` [s sim] (the vehicle's rest, the mission's end; None: unknown), and one estimate beyond (in
        lock-step, `ESTIMATE_SETTLE_S` beyond that, so the last estimates are looked up)."""
        known = [t for t in ends if t is not None]
        if not known:
            return False
        settle = ESTIMATE_SETTLE_S if self.lockstep else 0.0
        return await self.wait_truth(max(known) + RECORD_LEAD_S + ESTIMATE_LAG_S + self.estimate_period_s + settle)

    async def wait_rest(self, *, still_s: float = 1.0, max_sim_s: float = 30.0, max_wall_s: float = 20.0) -> float | None:
        """Wait until the true vehicle has stood still for `still_s` [s] sim; return when it stopped [s] sim.

        Gives up (None) after `max_sim_s` [s] sim or `max_wall_s` [s] wall.
        """
        loop = asyncio.get_running_loop()
        wall_end = loop.time() + max_wall_s
        sim_end = self.sim_time + max_sim_s
        while (left := wall_end - loop.time()) > 0 and self.sim_time <= sim_end:
            if (since := self.rest_since(still_s)) is not None:
                return since
            self._new_truth.clear()
            try:
                await asyncio.wait_for(self._new_truth.wait(), left)
            except (asyncio.TimeoutError, TimeoutError):
                break
        return None

    def process_costs(self) -> tuple[ProcessCost, ...]:
        """Return the newest usage heard from each process incarnation, by name then pid."""
        return tuple(self.costs[k] for k in sorted(self.costs))

    def _on_heartbeat(self, key: str, payload: bytes) -> None:
        try:
            hb = decode_heartbeat(payload)
        except HeartbeatError:
            self.bad_samples += 1
            return
        if hb.usage is not None:
            name = key.rsplit("/", 1)[-1]
            self.costs[(name, hb.pid)] = ProcessCost(name=name, pid=hb.pid, usage=hb.usage)
            self._new_usage.set()

    def _on_clock(self, _key: str, payload: bytes) -> None:
        with contextlib.suppress(WireError):
            self.clock = decode(SimClock, payload)

    async def close(self) -> None:
        """Wait for estimate look-ups in flight."""
        if self._tasks:
            await asyncio.gather(*self._tasks, return_exceptions=True)
