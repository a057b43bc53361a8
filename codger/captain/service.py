"""The CAPTAIN module: takes missions (files, or submitted over Zenoh), sequences their steps on the
blackboard one at a time, and keeps each mission's status (seed §2.3.1).

It never sees perception or the vehicle: it writes `mission`, `mission_step` and `mission_status`
tokens and reads `step_result` tokens. To answer where a running mission is (`sidewalk status`), it
looks every `progress_every_s` [s sim] at what the other modules posted: the step's newest `route_plan`,
the newest `position_estimate` (the robot's belief), and, while no progress is made, the newest
`obstacle_report` and `local_path_plan` (`modules.captain.progress`).
"""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from blackboard import AttrPredicate, BlackboardError, Spec, VersionConflictError

from modules.captain.missionfile import MissionFileError, MissionProblem, parse_mission, rejection_from
from modules.captain.progress import RouteProgress
from modules.captain.sequencer import MissionRun
from wire.keys import MissionKeys
from wire.mission import SubmitAccepted
from runtime import ModuleRuntime, ModuleWatch
from runtime.mission_desk import MissionDesk, MissionRejected
from modules.vocabulary import (
    LocalPathPlan, MapPlaces, Mission, MissionStatus, ObstacleReport, PositionEstimate, RoutePlan, StepResult, Waiting,
)

__all__ = ["Captain", "CaptainOptions"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CaptainOptions:
    """CAPTAIN settings: which module answers steps, how long it may vanish [s wall], step timeout [s sim],
    and how long [s wall] it has to acknowledge a step with a route plan (None: no bound)."""

    navigator: str = "map_navigator"
    navigator_grace_s: float = 15.0
    step_timeout_s: float | None = None
    ack_timeout_s: float | None = 60.0
    keep_finished: int = 100
    #: how often [s sim] the running step's progress is looked at
    progress_every_s: float = 2.0
    #: an obstacle report older than this [s sim] holds nothing any more
    obstacle_fresh_s: float = 2.0


@dataclass
class _Entry:
    run: MissionRun
    status_token: Any = None
    cancelled: asyncio.Event = field(default_factory=asyncio.Event)
    cancel_reason: str = ""
    #: the running step's progress along its route, the newest believed pose (x, y [m], yaw [rad] in `world`),
    #: its plan's revision, and why the vehicle waits
    track: RouteProgress | None = None
    revision: int = -1
    pose: tuple[float, float, float] | None = None
    waiting: Waiting = ""

    @property
    def status(self) -> MissionStatus:
        """Return the mission's status."""
        return self.run.status

    def cancel(self, now: float, reason: str) -> None:
        """Cancel the mission while it waits in the queue, at sim time `now` [s]."""
        self.run.cancel(now, reason)


class Captain:
    """The CAPTAIN service bound to a module runtime (blackboard client, Zenoh link, sim clock): the mission desk's room."""

    #: how the desk's rejections name this service
    noun = "CAPTAIN"

    def __init__(self, rt: ModuleRuntime, options: CaptainOptions = CaptainOptions()) -> None:
        self.rt = rt
        self.bb = rt.bb
        self.options = options
        self.desk: MissionDesk[_Entry] = MissionDesk(rt.link, MissionKeys(rt.keys.ns), self, self._now, keep_finished=options.keep_finished)
        self.navigator: ModuleWatch | None = None

    # ---- accepting missions -------------------------------------------------------------

    def _now(self) -> float:
        return self.rt.clock.now_or(0.0)

    async def accept(self, mission: Mission) -> SubmitAccepted:
        """Queue a validated mission (assigning an id if it has none); post its mission and status tokens."""
        mission = mission.model_copy(update={"mission_id": self.desk.unique_id(mission.mission_id, mission.name)})
        return await self.desk.accept(_Entry(MissionRun(mission, submitted_at=self._now())))

    def status(self, mission_id: str) -> MissionStatus | None:
        """Return the status of a mission this CAPTAIN knows, or None."""
        e = self.desk.entries.get(mission_id)
        return None if e is None else e.run.status

    def statuses(self) -> list[MissionStatus]:
        """Return the status of every mission known, oldest first."""
        return [e.run.status for e in self.desk.entries.values()]

    async def cancel(self, mission_id: str, reason: str = "cancelled by request") -> MissionStatus:
        """Cancel a queued or running mission; raise KeyError (unknown) or ValueError (already finished)."""
        await self.desk.cancel(mission_id, reason)
        return self.desk.entries[mission_id].run.status

    # ---- the desk's room ------------------------------------------------------------------

    async def admit(self, payload: bytes) -> _Entry:
        """Return the entry of a submitted mission whose destinations the map knows; raise MissionRejected."""
        try:
            mission = parse_mission(payload, source="submitted mission")
            await self.check_places(mission, source="submitted mission")
        except MissionFileError as exc:
            raise MissionRejected(rejection_from(exc)) from None
        mission = mission.model_copy(update={"mission_id": self.desk.unique_id(mission.mission_id, mission.name)})
        return _Entry(MissionRun(mission, submitted_at=self._now()))

    async def accepted(self, entry: _Entry, ahead: int) -> None:
        """Post the mission and its status token before it is queued."""
        await self.bb.post(entry.run.mission, stamp=self._now())
        entry.status_token = await self.bb.post(entry.run.status, stamp=self._now())
        m = entry.run.mission
        log.info("accepted mission %s (%s, %d steps)", m.mission_id, m.name, len(m.steps))

    async def cancel_running(self, entry: _Entry, reason: str) -> None:
        """Tell the running mission's loop to cancel it (its step is withdrawn there)."""
        entry.cancel_reason = reason
        entry.cancelled.set()

    # ---- blackboard writes ----------------------------------------------------------------

    async def stored(self, e: _Entry) -> None:
        """Keep the mission's status token on the blackboard up to date with its status."""
        st = e.run.status
        tok = e.status_token
        for _ in range(3 if tok is not None else 0):
            try:
                e.status_token = await self.bb.update(tok.id, st, expected_version=tok.version, stamp=self._now())
                return
            except VersionConflictError:
                found = await self.bb.retrieve(Spec(type="mission_status", where=(AttrPredicate(path="mission_id", op="==", value=st.mission_id),)))
                if not found:
                    break
                tok = found[0]
        e.status_token = await self.bb.post(st, stamp=self._now())

    async def check_places(self, mission: Mission, *, source: str) -> None:
        """Raise MissionFileError for a step whose destination the MAP NAVIGATOR's map does not know by name.

        The map's places come from the `map_places` token the MAP NAVIGATOR posts; before it did (or
        with the blackboard away) nothing can be checked here, and the step fails at run time instead.
        """
        try:
            found = await self.bb.retrieve(Spec(type="map_places"))
        except BlackboardError as exc:
            log.warning("cannot check the destinations of %s: %s", mission.name, exc)
            return
        known = next((t.attrs for t in found if isinstance(t.attrs, MapPlaces)), None)
        if known is None:
            return
        listed = ", ".join(known.places[:30]) + (", …" if len(known.places) > 30 else "")
        problems = [MissionProblem(None, None, f"steps[{i}].destination", f"unknown place {s.destination.place!r} on map "
                                   f"{known.map_name!r}; known places: {listed}")
                    for i, s in enumerate(mission.steps)
                    if s.destination.place is not None and not known.knows(s.destination.place)]
        if problems:
            raise MissionFileError(source, problems)

    async def fail_orphans(self) -> list[str]:
        """Fail every mission the blackboard shows queued or running that this CAPTAIN does not know; return their ids.

        A CAPTAIN that restarted lost its missions' progress: left alone, their statuses would say
        `running` forever with nobody working on them. Their open steps are withdrawn too, so the
        MAP NAVIGATOR stops driving them.
        """
        out = []
        for tok in await self.bb.retrieve(Spec(type="mission_status", where=(AttrPredicate(path="state", op="in", value=["queued", "running"]),))):
            st = tok.attrs
            if not isinstance(st, MissionStatus) or st.mission_id in self.desk.entries:
                continue
            reason = ("the CAPTAIN restarted while this mission was " + st.state
                      + ": its progress was lost; submit it again")
            done = st.model_copy(update={"state": "failed", "reason": reason, "finished_at": self._now()})
            try:
                await self.bb.update(tok.id, done, expected_version=tok.version, stamp=self._now())
            except VersionConflictError:
                continue
            for step_tok in await self.bb.retrieve(Spec(type="mission_step", where=(
                    AttrPredicate(path="mission_id", op="==", value=st.mission_id),
                    AttrPredicate(path="state", op="==", value="active")))):
                await self._withdraw(step_tok, step_tok.attrs)
            self.rt.link.put(self.rt.keys.mission_events, done.model_dump_json().encode(), as_json=True)
            log.warning("mission %s: %s", st.mission_id, reason)
            out.append(st.mission_id)
        return out

    # ---- running missions -----------------------------------------------------------------

    async def run(self) -> None:
        """Run queued missions one after the other, forever."""
        while True:
            e = await self.desk.next()
            mid = e.run.mission.mission_id
            try:
                await self._execute(e)
            except asyncio.CancelledError:
                raise
            except Exception as exc:  # a failure in one mission must not stop the CAPTAIN
                log.exception("mission %s failed inside the CAPTAIN", mid)
                e.run.fail(self._now(), f"captain error: {type(exc).__name__}: {exc}")
                try:
                    await self.desk.publish(e)
                except Exception:
                    log.exception("could not publish the status of %s", mid)

    async def _execute(self, e: _Entry) -> None:
        run = e.run
        step = run.start(self._now())
        await self.desk.publish(e)
        while True:
            step_tok = await self.bb.post(step, stamp=self._now())
            follow = asyncio.ensure_future(self._follow(e, step.step_index))
            try:
                outcome = await self._await_result(e, step.step_index)
            finally:
                follow.cancel()
                e.track, e.revision, e.waiting = None, -1, ""
            if isinstance(outcome, StepResult):
                nxt = run.step_finished(outcome, self._now())
                if nxt.kind == "wait":
                    await self.desk.publish(e)
                    if await self._wait_or_cancel(e, nxt.until):  # cancelled while waiting
                        await self._withdraw(step_tok, step)
                        run.cancel(self._now(), e.cancel_reason)
                        await self.desk.publish(e)
                        return
                    nxt = run.wait_over(self._now())
            else:  # cancelled, navigator lost, or timed out
                kind, reason = outcome
                await self._withdraw(step_tok, step)
                if kind == "cancel":
                    run.cancel(self._now(), reason)
                else:
                    run.fail(self._now(), reason)
                await self.desk.publish(e)
                return
            await self.desk.publish(e)
            if nxt.kind == "done":
                log.info("mission %s %s %s", run.mission.mission_id, run.status.state, run.status.reason)
                return
            assert nxt.step is not None
            step = nxt.step

    # ---- where the running step is (the robot's belief) ----------------------------------

    async def _follow(self, e: _Entry, index: int) -> None:
        """Look at step `index`'s progress every `progress_every_s` [s sim] until cancelled."""
        while True:
            try:
                await self._look(e, index)
            except BlackboardError as exc:  # the node away: look again later
                log.debug("progress of %s step %d: %s", e.run.mission.mission_id, index, exc)
            await self.rt.clock.sleep(self.options.progress_every_s)

    async def _newest(self, type_: str, *where: AttrPredicate) -> Any:
        found = await self.bb.retrieve(Spec(type=type_, where=where, newest=True))
        return found[0] if found else None

    async def _look(self, e: _Entry, index: int) -> None:
        """Update the step's progress from its newest route plan and position estimate; say why it waits."""
        now = self._now()
        mid = e.run.mission.mission_id
        plan = await self._newest("route_plan", AttrPredicate(path="mission_id", op="==", value=mid),
                                  AttrPredicate(path="step_index", op="==", value=index))
        rp = plan.attrs if plan is not None and isinstance(plan.attrs, RoutePlan) and len(plan.attrs.polyline) >= 2 else None
        if rp is not None and (e.track is None or rp.revision != e.revision):
            if e.track is None:
                started = e.run.status.steps[index].started_at if index < len(e.run.status.steps) else None
                e.track = RouteProgress(index, rp.polyline, now if started is None else started)
            else:
                e.track.reroute(rp.polyline)
            e.revision = rp.revision
        est = await self._newest("position_estimate")
        pe = est.attrs if est is not None and isinstance(est.attrs, PositionEstimate) else None
        if pe is not None:
            e.pose = (pe.pose.x, pe.pose.y, pe.pose.yaw)
            if e.track is not None:
                e.track.note(now, e.track.left(e.pose[:2]))
        e.waiting = await self._waiting(e, now, pe)

    async def _waiting(self, e: _Entry, now: float, pe: PositionEstimate | None) -> Waiting:
        """Return why the vehicle waits: an obstacle on the plan, nothing planned for the step yet, or no perception."""
        if e.track is None:
            return "planning"  # the MAP NAVIGATOR has not planned the step's route yet
        if e.track.since(now) >= self.options.progress_every_s:  # not getting farther: look for why
            obs = await self._newest("obstacle_report")
            rep = obs.attrs if obs is not None and isinstance(obs.attrs, ObstacleReport) else None
            if rep is not None and rep.blocked and now - rep.sensed_at <= self.options.obstacle_fresh_s:
                return "obstacle hold"
            lpp = await self._newest("local_path_plan")
            if lpp is None or not isinstance(lpp.attrs, LocalPathPlan) or lpp.stamp < e.track.best_at:
                return "planning"  # the PILOT has given the HELM nothing since the last progress
        return "dead reckoning" if pe is not None and pe.source == "dead-reckoning" else ""

    def answered(self, e: _Entry) -> MissionStatus:
        """Return `e`'s status as a status query is answered: a running mission's with where it is (`StepProgress`)."""
        st = e.run.status
        if st.state != "running" or e.track is None:
            return st
        return st.model_copy(update={"progress": e.track.report(self._now(), e.pose, e.waiting)})

    async def _withdraw(self, tok: Any, step: Any) -> None:
        for _ in range(3):
            try:
                await self.bb.update(tok.id, step.model_copy(update={"state": "cancelled"}), expected_version=tok.version, stamp=self._now())
                return
            except VersionConflictError:
                found = await self.bb.retrieve(Spec(type="mission_step", where=(
                    AttrPredicate(path="mission_id", op="==", value=step.mission_id),
                    AttrPredicate(path="step_index", op="==", value=step.step_index))))
                if not found:
                    return
                tok = found[0]
            except Exception as exc:
                log.warning("could not withdraw step %s/%d: %s", step.mission_id, step.step_index, exc)
                return

    async def _wait_or_cancel(self, e: _Entry, until: float) -> bool:
        wait = asyncio.ensure_future(self.rt.clock.wait_until(until))
        cancel = asyncio.ensure_future(e.cancelled.wait())
        try:
            done, _ = await asyncio.wait({wait, cancel}, return_when=asyncio.FIRST_COMPLETED)
            return cancel in done
        finally:
            wait.cancel()
            cancel.cancel()

    async def _await_result(self, e: _Entry, index: int) -> StepResult | tuple[str, str]:
        mid = e.run.mission.mission_id
        spec = Spec(type="step_result", where=(AttrPredicate(path="mission_id", op="==", value=mid),
                                               AttrPredicate(path="step_index", op="==", value=index)))
        result = asyncio.ensure_future(self.bb.wait(spec))
        cancel = asyncio.ensure_future(e.cancelled.wait())
        lost = asyncio.ensure_future(self.navigator.lost(self.options.navigator_grace_s) if self.navigator else asyncio.Event().wait())
        tasks = {result, cancel, lost}
        timer = unacked = None
        if self.options.step_timeout_s is not None:
            timer = asyncio.ensure_future(self.rt.clock.sleep(self.options.step_timeout_s))
            tasks.add(timer)
        if self.options.ack_timeout_s is not None:
            unacked = asyncio.ensure_future(self._unacknowledged(mid, index, self.options.ack_timeout_s))
            tasks.add(unacked)
        try:
            while True:
                done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
                if result in done and result.exception() is not None:
                    log.warning("waiting for the result of %s step %d failed (%r); waiting again", mid, index, result.exception())
                    await asyncio.sleep(0.5)  # wall-time back-off while the blackboard is unreachable
                    tasks.discard(result)
                    result = asyncio.ensure_future(self.bb.wait(spec))
                    tasks.add(result)
                    continue
                if unacked is not None and unacked in done and unacked.result() is None and len(done) == 1:
                    tasks.discard(unacked)  # acknowledged: the result is all that is left to wait for
                    continue
                break
            if result in done:
                return result.result().attrs
            if cancel in done:
                return ("cancel", e.cancel_reason)
            if lost in done:
                who = self.options.navigator.upper().replace("_", " ")
                return ("fail", f"step {index + 1}: the {who} went away ({lost.result()}) while the step waited for its result")
            if unacked is not None and unacked in done and unacked.result() is not None:
                return ("fail", unacked.result())
            return ("fail", f"step {index + 1} timed out after {self.options.step_timeout_s:.0f} s of sim time")
        finally:
            for t in tasks:
                t.cancel()

    async def _unacknowledged(self, mid: str, index: int, bound: float) -> str | None:
        """Return None once the navigator posts a route plan for the step, else the reason after `bound` [s] wall."""
        spec = Spec(type="route_plan", where=(AttrPredicate(path="mission_id", op="==", value=mid),
                                              AttrPredicate(path="step_index", op="==", value=index)))
        try:
            await self.bb.wait(spec, timeout=bound)
            return None
        except (asyncio.TimeoutError, TimeoutError):
            return (f"step {index + 1}: the {self.options.navigator.upper().replace('_', ' ')} did not acknowledge it "
                    f"(no route plan) within {bound:.0f} s")

    # ---- Zenoh services -------------------------------------------------------------------

    def declare(self) -> None:
        """Declare the mission desk's queryables and the navigator watch on the runtime's link."""
        self.desk.declare()
        self.navigator = ModuleWatch(self.rt.link, self.rt.keys, self.options.navigator)
