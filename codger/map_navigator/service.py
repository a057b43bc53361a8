"""The MAP NAVIGATOR module: mission steps → route plan → route segments, one at a time (seed §2.3.2).

Reads `mission_step` tokens (from the CAPTAIN) and `segment_result` tokens (from the PILOT); writes
`route_plan`, `route_segment` and `step_result` tokens. Only this module reads the map. It never
sees perception or the vehicle: where the vehicle is comes from the map's start and the PILOT's
segment results.
"""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass
from typing import Any

from blackboard import AttrPredicate, InvalidTokenError, Point, Polygon, Polyline, Spec, VersionConflictError

from modules.map_navigator.mapdata import MapData
from modules.map_navigator.stepjob import NavigatorOptions, Planned, StepJob
from runtime import ModuleRuntime, ModuleWatch
from modules.vocabulary import MapPlaces, MissionStep, RouteSegmentDescription, SegmentResult, StepResult

__all__ = ["MapNavigator", "ServiceOptions"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ServiceOptions:
    """Service settings: the PILOT's module name, how long it may vanish [s wall] mid-segment, and
    whether to store the map's objects on the blackboard (as `map_object` tokens, for monitors)."""

    pilot: str = "pilot"
    pilot_grace_s: float = 15.0
    post_map: bool = True


def _eq(path: str, value: Any) -> AttrPredicate:
    return AttrPredicate(path=path, op="==", value=value)


def _line(coords: tuple[tuple[float, float], ...]) -> Polyline:
    pts = list(coords)
    if len(pts) < 2 or (len(pts) == 2 and pts[0] == pts[1]):
        pts = [pts[0], (pts[0][0] + 1e-3, pts[0][1])]
    return Polyline(points=tuple(pts))


class MapNavigator:
    """The MAP NAVIGATOR service bound to a module runtime and a loaded map."""

    def __init__(self, rt: ModuleRuntime, m: MapData, start_xy: tuple[float, float],
                 options: NavigatorOptions = NavigatorOptions(), service: ServiceOptions = ServiceOptions()) -> None:
        self.rt = rt
        self.bb = rt.bb
        self.map = m
        self.position = start_xy
        self.options = options
        self.service = service
        self.pilot: ModuleWatch | None = None
        self._job_task: asyncio.Task[None] | None = None
        self._job_key: tuple[str, int] | None = None
        self._cancel = asyncio.Event()
        self._handled: set[tuple[str, int]] = set()

    def _now(self) -> float:
        return self.rt.clock.now_or(0.0)

    # ---- the main loop --------------------------------------------------------------------

    async def run(self) -> None:
        """Follow mission steps forever: start, cancel, and resume after a restart."""
        self.pilot = ModuleWatch(self.rt.link, self.rt.keys, self.service.pilot)
        await self.post_places()
        if self.service.post_map:
            await self.post_map()
        try:
            async with self.bb.monitor(Spec(type="mission_step")) as mon:
                await self._resume()
                async for ev in mon:
                    step: MissionStep = ev.token.attrs
                    key = (step.mission_id, step.step_index)
                    if ev.kind == "deleted" or step.state == "cancelled":
                        if self._job_key == key:
                            self._cancel.set()
                        continue
                    if ev.kind == "new" and key not in self._handled:
                        await self._start(step)
        finally:  # shutting down: the step stays open on the blackboard for a restarted navigator to resume
            if self._job_task is not None and not self._job_task.done():
                self._job_task.cancel()
                await asyncio.wait({self._job_task}, timeout=5.0)

    async def post_places(self) -> None:
        """Say on the blackboard which destinations this map knows by name (the CAPTAIN refuses others at submit)."""
        places = MapPlaces(map_name=self.map.name, places=self.map.place_names(),
                           nodes=tuple(sorted(n.id for n in self.map.world.nodes)))
        for tok in await self.bb.retrieve(Spec(type="map_places")):
            if tok.attrs == places:
                return
            await self.bb.delete(tok.id)
        await self.bb.post(places, stamp=self._now())

    async def post_map(self) -> int:
        """Store every map object on the blackboard once (skipped if this map is already there); return the count posted."""
        if await self.bb.retrieve(Spec(type="map_object", limit=1)):
            return 0
        n = 0
        for obj in self.map.descriptions.values():
            if obj.polygon is not None:
                geom: Any = Polygon(points=obj.polygon)
            else:
                assert obj.center is not None
                geom = Point(x=obj.center[0], y=obj.center[1])
            try:
                await self.bb.post(obj, geometry=geom, stamp=self._now())
                n += 1
            except InvalidTokenError as exc:
                log.warning("map object %s not stored: %s", obj.object_id, exc)
        log.info("stored %d map objects of %s on the blackboard", n, self.map.name)
        return n

    async def _resume(self) -> None:
        """Take up an active step that has no result yet (after a restart of this module)."""
        steps = await self.bb.retrieve(Spec(type="mission_step", where=(_eq("state", "active"),)))
        pending = []
        for tok in steps:
            st: MissionStep = tok.attrs
            done = await self.bb.retrieve(Spec(type="step_result", where=(_eq("mission_id", st.mission_id), _eq("step_index", st.step_index)), limit=1))
            if done:
                self._handled.add((st.mission_id, st.step_index))
            else:
                pending.append(tok)
        if not pending:
            return
        pending.sort(key=lambda t: t.stamp)
        for tok in pending[:-1]:  # only one step runs at a time: older leftovers are superseded
            self._handled.add((tok.attrs.mission_id, tok.attrs.step_index))
        await self._start(pending[-1].attrs, resume=True)

    async def _start(self, step: MissionStep, *, resume: bool = False) -> None:
        if self._job_task is not None and not self._job_task.done():
            log.warning("new step %s/%d while %s runs: the old one is withdrawn", step.mission_id, step.step_index, self._job_key)
            self._cancel.set()
            try:
                await self._job_task
            except Exception:
                pass
        self._handled.add((step.mission_id, step.step_index))
        self._cancel = asyncio.Event()
        self._job_key = (step.mission_id, step.step_index)
        self._job_task = asyncio.create_task(self._run_step(step, resume))

    # ---- one step -------------------------------------------------------------------------

    async def _run_step(self, step: MissionStep, resume: bool) -> None:
        try:
            res = await self._drive_step(step, resume)
        except asyncio.CancelledError:
            raise
        except Exception as exc:
            log.exception("step %s/%d failed inside the MAP NAVIGATOR", step.mission_id, step.step_index)
            res = StepResult(mission_id=step.mission_id, step_index=step.step_index, success=False,
                             reason=f"map navigator error: {type(exc).__name__}: {exc}")
        await self.bb.post(res, stamp=self._now())
        log.info("step %s/%d: %s %s", step.mission_id, step.step_index, "success" if res.success else "failure", res.reason)

    async def _resume_job(self, step: MissionStep) -> tuple[StepJob, RouteSegmentDescription | None]:
        """Rebuild a job from the blackboard: the newest plan, its pending segment, the position reached."""
        plans = await self.bb.retrieve(Spec(type="route_plan", where=(_eq("mission_id", step.mission_id), _eq("step_index", step.step_index))))
        if not plans:
            return StepJob(self.map, step, self.position, self.options), None
        plan = max(plans, key=lambda t: t.attrs.revision).attrs
        segs = await self.bb.retrieve(Spec(type="route_segment", where=(_eq("plan_id", plan.plan_id),)))
        results = await self.bb.retrieve(Spec(type="segment_result", where=(_eq("plan_id", plan.plan_id),)))
        by_seg = {r.attrs.segment_id: r.attrs for r in results}
        position = plan.start_xy
        pending = None
        job = StepJob(self.map, step, position, self.options, first_revision=plan.revision + 1)
        for tok in sorted(segs, key=lambda t: t.attrs.segment_index):
            s: RouteSegmentDescription = tok.attrs
            r = by_seg.get(s.segment_id)
            if r is None:
                if s.state == "active":
                    pending = s
                break
            if r.success:
                job.done_length += s.length_m
                job.segments_done += 1
                position = r.end_xy or s.exit.point
            else:
                position = r.end_xy or position
                break
        job.position = position
        return job, pending

    async def _drive_step(self, step: MissionStep, resume: bool) -> StepResult:
        pending: RouteSegmentDescription | None = None
        if resume:
            job, pending = await self._resume_job(step)
        else:
            job = StepJob(self.map, step, self.position, self.options)
        if pending is not None:  # the PILOT is still on a segment from before the restart
            outcome = await self._await_segment(pending, None)
            if isinstance(outcome, StepResult):
                return outcome
            job.position = outcome.end_xy or (pending.exit.point if outcome.success else job.position)
            if outcome.success:
                job.done_length += pending.length_m
                job.segments_done += 1
        out: Planned | StepResult | RouteSegmentDescription = job.plan()
        while True:
            if isinstance(out, StepResult):
                self.position = job.position
                return out
            if isinstance(out, Planned):
                if job.retried:
                    log.warning("plan %s: no way around the failed segment; trying the same way again from (%.1f, %.1f)",
                                out.plan.plan_id, *job.position)
                await self.bb.post(out.plan, geometry=_line(out.plan.polyline), stamp=self._now())
                seg = job.current()
                if seg is None:
                    self.position = job.position
                    return job.result  # type: ignore[return-value]
            else:
                seg = out
            tok = await self.bb.post(seg, geometry=_line(seg.centreline), stamp=self._now())
            res = await self._await_segment(seg, tok, job)
            if isinstance(res, StepResult):
                self.position = job.position
                return res
            out = job.segment_done(res)

    async def _await_segment(self, seg: RouteSegmentDescription, tok: Any, job: StepJob | None = None) -> SegmentResult | StepResult:
        """Wait for the PILOT's result on `seg`, or a cancel, or the PILOT going away."""
        spec = Spec(type="segment_result", where=(_eq("segment_id", seg.segment_id),))
        result = asyncio.ensure_future(self.bb.wait(spec))
        cancel = asyncio.ensure_future(self._cancel.wait())
        lost = asyncio.ensure_future(self.pilot.lost(self.service.pilot_grace_s) if self.pilot else asyncio.Event().wait())
        try:
            while True:
                done, _ = await asyncio.wait({result, cancel, lost}, return_when=asyncio.FIRST_COMPLETED)
                if result not in done or result.exception() is None:
                    break
                log.warning("waiting for the result of %s failed (%r); waiting again", seg.segment_id, result.exception())
                await asyncio.sleep(0.5)  # wall-time back-off while the blackboard is unreachable
                result = asyncio.ensure_future(self.bb.wait(spec))
            if result in done:
                return result.result().attrs
            reason = "cancelled by the CAPTAIN" if cancel in done else f"segment {seg.segment_index} ({seg.mode}) failed: {lost.result()}"
            await self._withdraw(seg, tok)
            if job is not None:
                return job.cancel(reason)
            return StepResult(mission_id=self._job_key[0] if self._job_key else "", step_index=self._job_key[1] if self._job_key else 0,
                              success=False, reason=reason)
        finally:
            for t in (result, cancel, lost):
                t.cancel()

    async def _withdraw(self, seg: RouteSegmentDescription, tok: Any) -> None:
        """Mark the segment cancelled so the PILOT stops driving it."""
        if tok is None:
            found = await self.bb.retrieve(Spec(type="route_segment", where=(_eq("segment_id", seg.segment_id),)))
            if not found:
                return
            tok = found[0]
        for _ in range(3):
            try:
                await self.bb.update(tok.id, seg.model_copy(update={"state": "cancelled"}), expected_version=tok.version, stamp=self._now())
                return
            except VersionConflictError:
                found = await self.bb.retrieve(Spec(type="route_segment", where=(_eq("segment_id", seg.segment_id),)))
                if not found:
                    return
                tok = found[0]
                seg = tok.attrs
