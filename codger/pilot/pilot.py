"""The PILOT process (seed: Sidewalk §2.3.3, Figure 6): the loop that wires its five parts.

DRIVING MONITOR (`driving_monitor`: route segments in, driving units out, segment results),
DRIVING UNIT FINDER (`driving_unit_finder`: PERCEPTION's results), POSITION ESTIMATOR
(`position_estimator`: the Kalman filter with PERCEPTION's and the laser landmark fixes, `world←local`
corrections, estimates), DRIVING UNIT
NAVIGATOR (`driving_unit_navigator`: local path constraints) and LOCAL PATH PLANNER
(`local_path_planner`: the plan for the HELM, in `local`). Each tick the loop predicts the
estimate, lets the finder resolve answered units, the monitor post units due, and the navigator
and planner extend the plan when a newer unit is resolved. Times are sim time [s].
"""

from __future__ import annotations

import asyncio
import logging
import math

from blackboard import Spec
from blackboard.errors import BlackboardError
from modules.captain.arrival import REST_TIMEOUT_S, RestDetector
from modules.pilot.config import PilotConfig
from runtime.watch import HeartbeatWatch
from codger.pilot.cross_country import CrossCountryDriving, plans_on_terrain
from codger.pilot.driving_monitor import DrivingMonitor
from codger.pilot.driving_unit_finder import DrivingUnitFinder
from codger.pilot.driving_unit_navigator import DrivingUnitNavigator, UnitConstraints
from codger.pilot.local_path_planner import LocalPathPlanning
from modules.pilot.local_path_constraints import ConstraintError
from modules.pilot.planner import PlannedPath, PlanningError
from modules.pilot.polyline import PolylineError
from codger.pilot.position_estimator import PositionEstimator
from modules.pilot.segment import SegmentDriver
from modules.vocabulary import RouteSegmentDescription

__all__ = ["Pilot"]

log = logging.getLogger(__name__)


class Pilot:
    """Run the PILOT on a module runtime `rt` (blackboard client `rt.bb`, sim clock `rt.clock`)."""

    def __init__(self, rt, cfg: PilotConfig) -> None:
        """Build the five parts (the planner seeded); nothing touches the network until run()."""
        self.rt = rt
        self.bb = rt.bb
        self.cfg = cfg
        self.estimator = PositionEstimator(rt.bb, rt.clock, cfg)
        self.monitor = DrivingMonitor(rt.bb, rt.clock, cfg, self.estimator)
        self.finder = DrivingUnitFinder(rt.bb, cfg, self.estimator)
        self.navigator = DrivingUnitNavigator(rt.bb, cfg)
        self.planner = LocalPathPlanning(rt.bb, cfg)
        #: the cross-country part: segments to an off-road goal are planned on the terrain tiles
        self.cross_country = CrossCountryDriving(self)
        self.plan_failures = 0
        self.landmark_events: asyncio.Queue = asyncio.Queue()
        #: the HELM's heartbeat: while it is silent (wedged) the vehicle cannot move, which is no lack of progress
        self.helm = HeartbeatWatch(rt.link, rt.keys, cfg.helm) if getattr(rt, "link", None) is not None else None
        self._resyncs = getattr(rt.bb, "resyncs", 0)
        self._was_stalled = False
        #: whether the vehicle stands still, from its odometry: a segment that stops is reported at rest
        self.rest = RestDetector()

    @property
    def stats(self) -> dict[str, int]:
        """Return the counters: plans posted, units posted, fixes used and refused by the gate, planning failures."""
        return {"plans": self.planner.seq, "units": self.monitor.units_posted, "fixes": self.estimator.fixes,
                "fixes_refused": self.estimator.fix_gate.refused, "landmark_fixes": self.estimator.landmark_fixes,
                "plan_failures": self.plan_failures}

    @staticmethod
    async def _pump(mon, queue: asyncio.Queue) -> None:
        async for ev in mon:
            queue.put_nowait(ev)

    # -- main ------------------------------------------------------------------------------------
    async def run(self) -> None:
        """Serve route segments one at a time until the runtime asks to stop."""
        rt = self.rt
        await rt.clock.wait_running()
        # Register the monitors before looking at what is already there: nothing falls in between.
        seg_mon = await self.bb.monitor(Spec(type="route_segment")).start()
        res_mon = await self.bb.monitor(Spec(type="perception_result")).start()
        lm_mon = await self.bb.monitor(Spec(type="landmark_fix")).start()
        tasks = [asyncio.ensure_future(self._pump(seg_mon, self.monitor.events)),
                 asyncio.ensure_future(self._pump(res_mon, self.finder.events)),
                 asyncio.ensure_future(self._pump(lm_mon, self.landmark_events))]
        try:
            pending = await self.monitor.resume_candidate()
            rt.ready()
            if pending is None and self.cfg.start_pose is not None:
                await self.estimator.start(None)  # post world←local at once when the start is known
            while not rt.stopping:
                seg_tok = pending or await self._next_segment()
                pending = None
                if seg_tok is None:
                    continue
                if not self.estimator.started:
                    await self.estimator.start(seg_tok.attrs)
                pending = await self._drive_segment(seg_tok)
        finally:
            for t in tasks:
                t.cancel()
            for mon in (seg_mon, res_mon, lm_mon):
                try:
                    await mon.close()
                except BlackboardError:
                    pass

    async def _next_segment(self):
        try:
            return await self.monitor.next_segment(1.0)
        except TimeoutError:
            if self.estimator.started:  # idle: keep the perceived position current
                await self.estimator.step()
                fixed = await self.landmark_fixes() is not None
                await self.estimator.post(force=fixed, source="perception" if fixed else "dead-reckoning")
            return None

    async def _drive_segment(self, seg_tok):
        """Drive one segment to its exit; post its result; return a newer segment that pre-empted it."""
        seg: RouteSegmentDescription = seg_tok.attrs
        if plans_on_terrain(seg):
            return await self.cross_country.drive(seg_tok)
        cfg, clock = self.cfg, self.rt.clock
        monitor, finder, estimator = self.monitor, self.finder, self.estimator
        try:
            drv = monitor.begin(seg, not finder.dead_reckoning)
        except (PolylineError, ValueError) as exc:
            await monitor.report(seg, False, f"bad segment geometry: {exc}")
            return None
        plan_failures = 0
        last_progress = (clock.now(), drv.s_vehicle)
        start_distance = estimator.distance_m
        log.info("pilot: segment %s (%s, %.1f m, %d units, perception %s)", seg.segment_id, seg.mode, drv.geom.path.length,
                 len(drv.units), "on" if drv.use_perception else "off")
        while not self.rt.stopping:
            now = clock.now()
            if self._stalled():
                # the node away or the HELM wedged: the stuck timer starts afresh once both are back,
                # and the plan is made again from where the vehicle stands
                last_progress = (now, drv.s_vehicle)
                drv.planned_through = -1
            await estimator.step()
            drv.update_progress(estimator.pose[:2])
            change = await monitor.change(seg)
            if change is not None:
                return change.by
            fixed_unit = await finder.collect(seg, drv, monitor.unit_index)
            if fixed_unit is not None:
                drv.update_progress(estimator.pose[:2])
                await estimator.post(force=True, source="perception", unit_id=fixed_unit)
                drv.planned_through = -1  # world←local moved: replan from the corrected pose
            moved = await self.landmark_fixes()
            if moved is not None:
                drv.update_progress(estimator.pose[:2])
                await estimator.post(force=True, source="perception")
                if moved > cfg.landmark_replan_m:
                    drv.planned_through = -1
            finder.time_out(drv, now)
            finder.skip(drv, await monitor.post_units(seg, drv, now))
            await estimator.post(source="perception" if drv.perceived_count else "dead-reckoning")
            mode = f"{drv.perceived_count}/{len(drv.units)} units perceived" + (", dead reckoning" if finder.dead_reckoning else "")
            if drv.exited(estimator.pose[:2]):
                # Before planning: a fix that moved the estimate into the exit would otherwise have
                # the vehicle manoeuvre to a goal the segment no longer needs.
                if seg.constraints.stop_at_exit:  # the vehicle stops here: arrival is claimed at rest
                    return await self._come_to_rest(seg, f"exit reached ({mode})", start_distance)
                await monitor.report(seg, True, f"exit reached ({mode})", start_distance)
                return None
            if drv.needs_plan():
                t_plan = clock.now()
                try:
                    await self._plan(seg, drv)
                    plan_failures = 0
                except (PlanningError, ConstraintError) as exc:
                    plan_failures += 1
                    self.plan_failures += 1
                    log.warning("pilot: planning failed (%d): %s", plan_failures, exc)
                    if plan_failures >= cfg.max_plan_failures:
                        await monitor.report(seg, False, f"local path planning failed: {exc}", start_distance)
                        await monitor.cancel_units()
                        return None
                finally:
                    # The sim time the PILOT spent planning (its wall-clock work × RTF) is not time the
                    # vehicle stood still with a plan to drive: the stuck timer does not count it.
                    last_progress = (last_progress[0] + max(0.0, clock.now() - t_plan), last_progress[1])
            if drv.s_vehicle > last_progress[1] + 0.2:
                last_progress = (now, drv.s_vehicle)
            elif now - last_progress[0] > cfg.final_goal_settle_s and drv.at_final_goal():
                # Standing at the end of a plan through the last unit: the region allows no farther.
                await monitor.report(seg, True, f"end of the navigable region at s={drv.s_vehicle:.1f} of {drv.geom.path.length:.1f} m ({mode})",
                                     start_distance)
                return None
            elif now - last_progress[0] > cfg.replan_idle_s and now - self.planner.last_plan_t > cfg.replan_idle_s:
                # Standing still with nothing new: plan again from here (a restarted HELM, a detour).
                drv.planned_through = -1
            if now - last_progress[0] > cfg.stuck_timeout_s:
                await monitor.report(seg, False, f"no progress for {cfg.stuck_timeout_s:.0f} s at s={drv.s_vehicle:.1f} m", start_distance)
                await monitor.cancel_units()
                return None
            await clock.sleep(cfg.tick_s)
        return None

    async def _feed_rest(self) -> None:
        """Feed the rest detector the odometry (`local←vehicle`) of one tick ago, if the HELM has posted that far.

        The pose at a time, not the newest: a HELM held up posts nothing new, and a repeated pose is no rest.
        """
        t = self.rt.clock.now() - self.cfg.tick_s
        try:
            p = await self.bb.lookup_pose(parent="local", child="vehicle", stamp=t)
        except BlackboardError:  # not posted that far yet (or the node away): no evidence either way
            return
        self.rest.feed(t, p.x, p.y, p.yaw)

    async def _come_to_rest(self, seg: RouteSegmentDescription, reason: str, start_distance: float):
        """Report the exit of a segment that stops there once the vehicle is at rest (`modules.captain.arrival`).

        Meanwhile the HELM drives out the plan, which stops at its end, and the estimate stays current;
        return a newer segment that pre-empts this one (None once reported).
        """
        clock, estimator = self.rt.clock, self.estimator
        arrived = clock.now()
        self.rest = RestDetector()
        while not self.rt.stopping:
            await self._feed_rest()
            now = clock.now()
            if self.rest.at_rest(now):
                await self.monitor.report(seg, True, f"{reason}; at rest", start_distance)
                return None
            if now - arrived >= REST_TIMEOUT_S:
                await self.monitor.report(seg, True, f"{reason}; not at rest {REST_TIMEOUT_S:.0f} s after (claimed anyway)",
                                          start_distance)
                return None
            await clock.sleep(self.cfg.tick_s)
            await estimator.step()
            change = await self.monitor.change(seg)
            if change is not None:
                return change.by
            fixed = await self.landmark_fixes() is not None
            await estimator.post(force=fixed, source="perception" if fixed else "dead-reckoning")
        return None

    async def landmark_fixes(self) -> float | None:
        """Fold in the laser landmark fixes posted since the last call; return how far [m] they moved the estimate (None: none used)."""
        if not self.estimator.started:
            return None
        before = self.estimator.pose
        used = False
        while not self.landmark_events.empty():
            ev = self.landmark_events.get_nowait()
            if ev.kind == "new":
                used = await self.estimator.apply_landmark_fix(ev.token.attrs) or used
        if not used:
            return None
        after = self.estimator.pose
        return math.hypot(after[0] - before[0], after[1] - before[1])

    def _stalled(self) -> bool:
        """Return whether the blackboard node is away (or was since the last call) or the HELM is silent."""
        bb = self.bb
        resyncs = getattr(bb, "resyncs", 0)
        stalled = resyncs != self._resyncs or getattr(bb, "link_state", "up") != "up"
        self._resyncs = resyncs
        if self.helm is not None and self.helm.silent:
            stalled = True
        if stalled != self._was_stalled:
            self._was_stalled = stalled
            log.warning("pilot: %s", "the blackboard node or the HELM is away: the stuck timer waits" if stalled
                        else "the blackboard node and the HELM are back: planning again from here")
        return stalled

    @staticmethod
    def _stops_at(seg: RouteSegmentDescription, drv: SegmentDriver, uc: UnitConstraints) -> bool:
        """Return whether the plan over `uc` ends in a stop (its newest unit is the last of a segment that stops at its exit)."""
        return drv.units[uc.indices[-1]].span.last and seg.constraints.stop_at_exit

    async def _plan(self, seg: RouteSegmentDescription, drv: SegmentDriver) -> None:
        """DRIVING UNIT NAVIGATOR, then LOCAL PATH PLANNER: constraints and a plan through the newest resolved unit."""
        start = self.estimator.pose
        sigma = self.estimator.sigma_xy()
        alternatives = self.navigator.alternatives(drv)
        uc: UnitConstraints | None = None
        path: PlannedPath | None = None
        usable: list[UnitConstraints] = []  # constraints a forward path was searched in, in order
        for k, (regions, perceived) in enumerate(alternatives):
            final = k == len(alternatives) - 1
            try:
                uc = self.navigator.constrain(seg, drv, regions, perceived, sigma=sigma, must_reach_exit=not final)
                usable.append(uc)
                path = await self.planner.plan(start, list(uc.goals), uc.constraints.region,
                                               relax_goal=not self._stops_at(seg, drv, uc), reverse=False)
                break
            except (ConstraintError, PlanningError) as exc:
                if final and not usable:
                    raise
                if not final:
                    log.warning("pilot: perceived regions unusable (%s); planning on the map's", exc)
        if path is None:
            # No forward path in any region: only now may the vehicle reverse (a manoeuvre it tracks
            # less well than a forward path, so never preferred to one in the map's region).
            for k, cand in enumerate(usable):
                try:
                    path = await self.planner.plan_reversing(start, list(cand.goals), cand.constraints.region)
                except PlanningError:
                    if k == len(usable) - 1:
                        raise
                    continue
                uc = cand
                log.warning("pilot: no forward path to the goal; reversing")
                break
        assert uc is not None and path is not None
        newest = uc.indices[-1]
        stop_here = self._stops_at(seg, drv, uc)
        speed_limit = self.navigator.speed_limit(seg)
        unit_ids = self.monitor.unit_ids
        now = self.rt.clock.now()
        await self.navigator.post(seg, uc, start, unit_ids.get(newest, f"{seg.segment_id}.u{newest}"), speed_limit, stop_here, now)
        await self.planner.post(seg, path, self.estimator.world_from_local(), tuple(unit_ids[i] for i in uc.indices if i in unit_ids),
                                speed_limit, stop_here, now, sensed_at=drv.sensed_at(list(uc.indices)))
        drv.mark_planned(newest, float(uc.constraints.goal_s[-1]))
