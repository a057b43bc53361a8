"""The PILOT process: driving monitor, driving unit finder, position estimator, navigator, planner.

Reads route segments, driving unit results and the `local←vehicle` poses from the blackboard;
posts driving units, position estimates, the `world←local` correction, local path constraints,
local path plans (in the `local` frame, for the HELM) and segment results. Times are sim time [s].
"""

from __future__ import annotations

import asyncio
import logging
import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Point
from shapely.geometry import Polygon as ShPolygon

from blackboard import AttrPredicate, Spec
from blackboard import Polygon as BbPolygon
from blackboard import Polyline as BbPolyline
from blackboard import Pose2D
from blackboard.errors import BlackboardError
from modules.pilot.config import PilotConfig
from modules.pilot.driving_units import ExpectedObject
from modules.pilot.kalman import EstimatorError, LineFix, PointFix, PoseFilter
from modules.pilot.navigator import ConstraintError, local_constraints
from modules.pilot.planner import LocalPathPlanner, PlanningError
from modules.pilot.polyline import PathLine, PolylineError
from wire.se2 import compose, inverse, transform_points
from modules.pilot.segment import SegmentDriver, SegmentGeometry, as_ring, fuse_regions, map_region
from modules.pilot.speed_profile import speed_profile
from modules.vocabulary import (
    DrivingUnitDescription, LocalPathConstraints, LocalPathPlan, MapObject, PerceptionResult, PlanPose,
    PositionEstimate, RouteSegmentDescription, SegmentResult,
)
from modules.vocabulary import LineFix as VLineFix
from modules.vocabulary import PointFix as VPointFix
from modules.vocabulary import Pose as VPose

__all__ = ["Pilot", "segment_geometry", "object_geometry"]

log = logging.getLogger(__name__)


def object_geometry(obj: MapObject):
    """Return a map object's footprint as a shapely geometry (world [m])."""
    if obj.polygon is not None:
        g = ShPolygon(obj.polygon)
        return g if g.is_valid else g.buffer(0)
    return Point(obj.center).buffer(obj.radius or 0.0)


def segment_geometry(seg: RouteSegmentDescription, extend_m: float = 0.0) -> SegmentGeometry:
    """Return the PILOT's view of a route segment: centreline, map region, objects, exit (world).

    The region reaches `extend_m` [m] past both ends of the centreline (the path goes on there:
    route segments meet end to end), so a long vehicle's body fits at the segment's ends.
    """
    path = PathLine.from_points(seg.centreline)
    paths = [object_geometry(o) for o in seg.objects if o.object_id in seg.path_object_ids and o.polygon is not None]
    line = path.xy
    if extend_m > 0.0:
        h0, h1 = path.heading_at(0.0), path.heading_at(path.length)
        line = np.vstack([line[0] - extend_m * np.array([math.cos(h0), math.sin(h0)]), line,
                          line[-1] + extend_m * np.array([math.cos(h1), math.sin(h1)])])
    region = map_region(line, seg.width_m, paths)
    # Anything standing (posts, trees, walls, buildings) or marked an obstacle is kept clear of.
    standing = tuple(
        object_geometry(o) for o in seg.objects
        if o.object_id not in seg.path_object_ids and (o.role == "obstacle" or o.shape.type in ("prism", "tree", "post"))
    )
    objs = tuple(ExpectedObject(o.object_id, object_geometry(o)) for o in seg.objects)
    return SegmentGeometry(path=path, region=region, objects=objs, exit_point=tuple(seg.exit.point),
                           exit_radius=seg.exit.radius_m, obstacles=standing)


@dataclass
class _Odom:
    stamp: float
    pose: np.ndarray


class Pilot:
    """Run the PILOT on a module runtime `rt` (blackboard client `rt.bb`, sim clock `rt.clock`)."""

    def __init__(self, rt, cfg: PilotConfig) -> None:
        """Prepare the planner (seeded) and the state; nothing touches the network until run()."""
        self.rt = rt
        self.bb = rt.bb
        self.cfg = cfg
        self.planner = LocalPathPlanner(cfg.planner, seed=cfg.seed)
        self.filter: PoseFilter | None = None
        self.odom: _Odom | None = None
        self.plan_seq = 0
        self.perception_misses = 0
        self.dead_reckoning = cfg.perception == "off"
        self._segment_events: asyncio.Queue = asyncio.Queue()
        self._unit_events: asyncio.Queue = asyncio.Queue()
        self._done_segments: set[str] = set()
        self._fixes_seen: set[tuple[str, float]] = set()
        self._last_correction = -math.inf
        self._last_plan_t = -math.inf
        self.stats = {"plans": 0, "units": 0, "fixes": 0, "plan_failures": 0}

    # -- odometry and position estimation ------------------------------------------------------
    async def _read_odometry(self) -> _Odom | None:
        try:
            p = await self.bb.lookup_pose(parent="local", child="vehicle", stamp=None)
        except BlackboardError:
            return None
        return _Odom(stamp=self.rt.clock.now(), pose=np.array([p.x, p.y, p.yaw]))

    async def _wait_odometry(self) -> _Odom:
        while True:
            o = await self._read_odometry()
            if o is not None:
                return o
            await self.rt.clock.sleep(self.cfg.tick_s)

    async def _init_filter(self, first_segment: RouteSegmentDescription | None) -> bool:
        """Start the estimator from the blackboard's world←local, the configured start, or the segment."""
        self.odom = await self._wait_odometry()
        cfg = self.cfg
        start: np.ndarray | None = None
        how = ""
        try:
            # A correction left by an earlier PILOT of this run (restart): keep its perception fixes.
            # One stamped after the current sim time belongs to an earlier simulator run: ignore it.
            info = await self.bb.frames()
            edge = info.edge("world", "local")
            if edge is not None and edge.newest is not None and edge.newest <= self.rt.clock.now() + 1.0:
                wl = await self.bb.lookup_pose(parent="world", child="local", stamp=None)
                start = compose(np.array([wl.x, wl.y, wl.yaw]), self.odom.pose)
                how = "previous world←local correction"
        except BlackboardError:
            pass
        # The local frame's origin is where the vehicle stood when odometry started: world←vehicle
        # now is world←local ∘ local←vehicle.
        if start is None and cfg.start_pose is not None:
            start = compose(np.array(cfg.start_pose, dtype=np.float64), self.odom.pose)
            how = "configured start pose"
        if start is None and first_segment is not None:
            path = PathLine.from_points(first_segment.centreline)
            p = path.point_at(0.0)
            start = compose(np.array([p[0], p[1], path.heading_at(0.0)]), self.odom.pose)
            how = "start of the first route segment"
        if start is None:
            return False  # wait for the first route segment to say where we are
        cov = np.diag([cfg.start_sigma_xy**2, cfg.start_sigma_xy**2, cfg.start_sigma_yaw**2])
        self.filter = PoseFilter(start, cov, cfg.odometry)
        log.info("pilot: estimator starts at %s (%s)", np.round(start, 3).tolist(), how)
        await self._post_correction(force=True, source="dead-reckoning")
        return True

    async def _step_estimator(self) -> None:
        o = await self._read_odometry()
        if o is None or self.filter is None or self.odom is None:
            return
        delta = PoseFilter.motion(self.odom.pose, o.pose)
        self.filter.predict(delta)
        self.odom = o

    async def _post_correction(self, *, force: bool = False, source: str = "dead-reckoning", unit_id: str | None = None) -> None:
        now = self.rt.clock.now()
        if not force and now - self._last_correction < self.cfg.correction_period_s:
            return
        self._last_correction = now
        wl = self.filter.world_from_local(self.odom.pose)
        await self.bb.post_pose(
            parent="world", child="local", pose=Pose2D(x=float(wl[0]), y=float(wl[1]), yaw=float(wl[2])), stamp=now, hold=None
        )
        p, c = self.filter.pose, self.filter.cov
        est = PositionEstimate(
            pose=VPose(x=p[0], y=p[1], yaw=p[2]),
            covariance=tuple(float(v) for v in (0.5 * (c + c.T)).reshape(-1)),
            source=source,
            unit_id=unit_id,
        )
        await self.bb.post(est, frame="world", geometry=None, stamp=now)

    def _sigma_xy(self) -> float:
        """Return the largest position standard deviation of the estimate [m]."""
        return float(math.sqrt(max(np.linalg.eigvalsh(self.filter.cov[:2, :2]).max(), 0.0)))

    async def _motion_since(self, stamp: float) -> np.ndarray:
        try:
            then = await self.bb.lookup_pose(parent="local", child="vehicle", stamp=stamp)
        except BlackboardError:
            return np.zeros(3)
        return PoseFilter.motion(np.array([then.x, then.y, then.yaw]), self.odom.pose)

    async def _apply_fix(self, res: PerceptionResult) -> bool:
        fix = res.fix
        key = (res.unit_id, res.captured_at)
        if fix is None or self.filter is None or key in self._fixes_seen:
            return False  # (a result may arrive both in its driving unit and on its own: use it once)
        self._fixes_seen.add(key)
        motion = await self._motion_since(res.captured_at)
        try:
            if isinstance(fix, VPointFix):
                self.filter.update_point(
                    PointFix(pose=np.array([fix.pose.x, fix.pose.y, fix.pose.yaw]), cov=np.array(fix.covariance).reshape(3, 3)),
                    motion_since=motion,
                )
            elif isinstance(fix, VLineFix):
                self.filter.update_line(
                    LineFix(point=np.array(fix.point), angle=fix.direction, cross_var=max(fix.lateral_var, 1e-6),
                            yaw=fix.yaw, yaw_var=None if fix.yaw_var is None else max(fix.yaw_var, 1e-8)),
                    motion_since=motion,
                )
        except EstimatorError as exc:
            log.warning("pilot: perception fix for %s ignored: %s", res.unit_id, exc)
            return False
        self.stats["fixes"] += 1
        return True

    async def _ring_in_world(self, ring, res: PerceptionResult):
        pts = np.asarray(ring, dtype=np.float64)
        if res.frame != "world":
            pts = np.asarray(
                await self.bb.transform(pts, src_frame=res.frame, src_stamp=res.captured_at, dst_frame="world", dst_stamp=res.captured_at)
            )
        g = ShPolygon(pts)
        return g if g.is_valid else g.buffer(0)

    async def _region_in_world(self, res: PerceptionResult, map_unit):
        """Return the unit's region from PERCEPTION's navigable region and view frame (world), or None."""
        if res.navigable_region is None:
            return None
        try:
            nav = await self._ring_in_world(res.navigable_region, res)
            vf = await self._ring_in_world(res.view_frame, res) if res.view_frame is not None else None
        except BlackboardError as exc:
            log.warning("pilot: cannot bring %s's region to world: %s", res.unit_id, exc)
            return None
        return fuse_regions(nav, vf, map_unit)

    # -- blackboard listeners ------------------------------------------------------------------
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
        unit_mon = await self.bb.monitor(Spec(any_of=(Spec(type="driving_unit"), Spec(type="perception_result")))).start()
        seg_task = asyncio.ensure_future(self._pump(seg_mon, self._segment_events))
        unit_task = asyncio.ensure_future(self._pump(unit_mon, self._unit_events))
        try:
            pending = await self._resume_candidate()
            rt.ready()
            if pending is None and self.cfg.start_pose is not None:
                await self._init_filter(None)  # post world←local at once when the start is known
            while not rt.stopping:
                seg_tok = pending or await self._next_segment()
                pending = None
                if seg_tok is None:
                    continue
                if self.filter is None:
                    await self._init_filter(seg_tok.attrs)
                pending = await self._drive_segment(seg_tok)
        finally:
            seg_task.cancel()
            unit_task.cancel()
            for mon in (seg_mon, unit_mon):
                try:
                    await mon.close()
                except BlackboardError:
                    pass

    async def _resume_candidate(self):
        """Return an active segment nobody reported on yet (the PILOT restarted mid-segment), or None."""
        try:
            toks = await self.bb.retrieve(Spec(type="route_segment", where=(AttrPredicate(path="state", op="==", value="active"),), newest=True))
        except BlackboardError as exc:
            log.warning("pilot: cannot look for an active segment: %s", exc)
            return None
        for t in toks:
            done = await self.bb.retrieve(Spec(type="segment_result", where=(AttrPredicate(path="segment_id", op="==", value=t.attrs.segment_id),)))
            if not done:
                return t
            self._done_segments.add(t.attrs.segment_id)
        return None

    async def _next_segment(self):
        try:
            ev = await self.rt.clock.wait_for(self._segment_events.get(), 1.0)
        except TimeoutError:
            await self._idle()
            return None
        seg = ev.token.attrs
        if ev.kind == "deleted" or seg.state != "active" or seg.segment_id in self._done_segments:
            return None
        return ev.token

    async def _idle(self) -> None:
        if self.filter is not None:
            await self._step_estimator()
            await self._post_correction(source="dead-reckoning")

    async def _drive_segment(self, seg_tok):
        """Drive one segment to its exit; post its result; return a newer segment that pre-empted it."""
        seg: RouteSegmentDescription = seg_tok.attrs
        cfg = self.cfg
        try:
            geom = segment_geometry(seg, cfg.region_extension_m)
        except (PolylineError, ValueError) as exc:
            await self._report(seg, False, f"bad segment geometry: {exc}")
            return None
        use_perception = not self.dead_reckoning
        drv = SegmentDriver(geom, cfg.units, cfg.lookahead_m, cfg.perception_timeout_s, use_perception)
        unit_ids: dict[int, str] = {}
        by_id: dict[str, int] = {}
        speed_limit = min(cfg.max_speed, seg.constraints.speed_limit or cfg.max_speed)
        keep = seg.constraints.keep or "none"
        plan_failures = 0
        last_progress = (self.rt.clock.now(), drv.s_vehicle)
        start_distance = self.filter.distance_m
        log.info("pilot: segment %s (%s, %.1f m, %d units, perception %s)", seg.segment_id, seg.mode, geom.path.length,
                 len(drv.units), "on" if use_perception else "off")
        while not self.rt.stopping:
            now = self.rt.clock.now()
            await self._step_estimator()
            xy = self.filter.pose[:2]
            drv.update_progress(xy)
            # Segment withdrawn or superseded?
            while not self._segment_events.empty():
                ev = self._segment_events.get_nowait()
                other = ev.token.attrs
                if other.segment_id == seg.segment_id:
                    if ev.kind == "deleted" or other.state == "cancelled":
                        log.info("pilot: segment %s cancelled", seg.segment_id)
                        await self._cancel_units(unit_ids)
                        return None
                elif ev.kind != "deleted" and other.state == "active" and other.segment_id not in self._done_segments:
                    # The MAP NAVIGATOR has moved on (one segment at a time): follow it, report nothing.
                    log.info("pilot: segment %s superseded by %s", seg.segment_id, other.segment_id)
                    self._done_segments.add(seg.segment_id)
                    await self._cancel_units(unit_ids)
                    return ev.token
            # DRIVING UNIT FINDER: results written back by PERCEPTION.
            fixed_unit = None
            while not self._unit_events.empty():
                ev = self._unit_events.get_nowait()
                # PERCEPTION writes its result into the driving unit, or posts it on its own.
                res = ev.token.attrs if isinstance(ev.token.attrs, PerceptionResult) else getattr(ev.token.attrs, "result", None)
                if ev.kind == "deleted" or res is None or res.segment_id != seg.segment_id or res.unit_id not in by_id:
                    continue
                i = by_id[res.unit_id]
                if drv.units[i].phase == "resolved" and (drv.units[i].perceived or res.status != "perceived"):
                    continue
                region = await self._region_in_world(res, drv.units[i].span.region) if res.status == "perceived" else None
                if res.status == "perceived" and await self._apply_fix(res):
                    fixed_unit = res.unit_id
                if drv.units[i].phase != "resolved" or region is not None:
                    drv.resolve(i, region, res.status == "perceived", f"perception {res.status}")
                    drv.planned_through = min(drv.planned_through, i - 1)  # a late region still reshapes the plan
                self.perception_misses = 0
                if self.dead_reckoning and cfg.perception == "auto":
                    log.info("pilot: PERCEPTION answered again: leaving dead reckoning")
                    self.dead_reckoning = False
                    drv.use_perception = True
            if fixed_unit is not None:
                drv.update_progress(self.filter.pose[:2])
                await self._post_correction(force=True, source="perception", unit_id=fixed_unit)
                drv.planned_through = -1  # world←local moved: replan from the corrected pose
            for i in drv.overdue(now):
                drv.resolve(i, None, False, "perception timeout")
                self.perception_misses += 1
                if cfg.perception == "auto" and self.perception_misses >= cfg.max_perception_misses and not self.dead_reckoning:
                    log.warning("pilot: no PERCEPTION result for %d units: dead reckoning on the map", self.perception_misses)
                    self.dead_reckoning = True
                    drv.use_perception = False
            # DRIVING MONITOR: post the next driving units.
            for i in drv.units_to_post(now):
                tok = await self._post_unit(seg, drv, i)
                unit_ids[i] = tok.attrs.unit_id
                by_id[tok.attrs.unit_id] = i
                if not drv.use_perception:
                    drv.resolve(i, None, False, "dead reckoning")
            # DRIVING UNIT NAVIGATOR + LOCAL PATH PLANNER.
            if drv.needs_plan():
                t_plan = self.rt.clock.now()
                try:
                    await self._plan(seg, drv, unit_ids, keep, speed_limit)
                    plan_failures = 0
                except (PlanningError, ConstraintError) as exc:
                    plan_failures += 1
                    self.stats["plan_failures"] += 1
                    log.warning("pilot: planning failed (%d): %s", plan_failures, exc)
                    if plan_failures >= cfg.max_plan_failures:
                        await self._report(seg, False, f"local path planning failed: {exc}", start_distance)
                        await self._cancel_units(unit_ids)
                        return None
                finally:
                    # The sim time the PILOT spent planning (its wall-clock work × RTF) is not time the
                    # vehicle stood still with a plan to drive: the stuck timer does not count it.
                    last_progress = (last_progress[0] + max(0.0, self.rt.clock.now() - t_plan), last_progress[1])
            await self._post_correction(source="perception" if drv.perceived_count else "dead-reckoning")
            mode = f"{drv.perceived_count}/{len(drv.units)} units perceived" + (", dead reckoning" if self.dead_reckoning else "")
            if drv.exited(self.filter.pose[:2]):
                await self._report(seg, True, f"exit reached ({mode})", start_distance)
                return None
            if drv.s_vehicle > last_progress[1] + 0.2:
                last_progress = (now, drv.s_vehicle)
            elif now - last_progress[0] > cfg.final_goal_settle_s and drv.at_final_goal():
                # Standing at the end of a plan through the last unit: the region allows no farther.
                await self._report(seg, True, f"end of the navigable region at s={drv.s_vehicle:.1f} of {drv.geom.path.length:.1f} m ({mode})",
                                   start_distance)
                return None
            elif now - last_progress[0] > cfg.replan_idle_s and now - self._last_plan_t > cfg.replan_idle_s:
                # Standing still with nothing new: plan again from here (a restarted HELM, a detour).
                drv.planned_through = -1
            if now - last_progress[0] > cfg.stuck_timeout_s:
                await self._report(seg, False, f"no progress for {cfg.stuck_timeout_s:.0f} s at s={drv.s_vehicle:.1f} m", start_distance)
                await self._cancel_units(unit_ids)
                return None
            await self.rt.clock.sleep(cfg.tick_s)
        return None

    async def _post_unit(self, seg: RouteSegmentDescription, drv: SegmentDriver, i: int):
        span = drv.units[i].span
        ring = as_ring(span.region)
        sd = math.sqrt(max(self.filter.cov[0, 0], self.filter.cov[1, 1]))
        objs = tuple(o for o in seg.objects if o.object_id in span.object_ids)
        du = DrivingUnitDescription(
            unit_id=f"{seg.segment_id}.u{i}",
            segment_id=seg.segment_id,
            unit_index=i,
            mode=seg.mode,
            region=ring,
            centreline=tuple((float(x), float(y)) for x, y in span.centerline),
            objects=objs,
            error_allowance_m=float(3.0 * sd),
            heading_allowance_rad=float(3.0 * math.sqrt(self.filter.cov[2, 2])),
        )
        self.stats["units"] += 1
        return await self.bb.post(du, frame="world", geometry=BbPolygon(points=ring), stamp=self.rt.clock.now())

    async def _cancel_units(self, unit_ids: dict[int, str]) -> None:
        for uid in unit_ids.values():
            try:
                toks = await self.bb.retrieve(Spec(type="driving_unit", where=(AttrPredicate(path="unit_id", op="==", value=uid),
                                                                             AttrPredicate(path="status", op="==", value="pending"))))
                for t in toks:
                    await self.bb.update(t.id, t.attrs.model_copy(update={"status": "cancelled"}), expected_version=t.version)
            except BlackboardError as exc:
                log.info("pilot: could not cancel %s: %s", uid, exc)

    async def _plan(self, seg: RouteSegmentDescription, drv: SegmentDriver, unit_ids, keep: str, speed_limit: float) -> None:
        regions, far_s, perceived, idx = drv.plan_inputs()
        c = seg.constraints
        offset = c.lateral_offset_m if (c.keep is not None and c.lateral_offset_m != 0.0) else None
        kw = dict(keep=keep, cfg=self.cfg.navigator, lateral_offset=offset, obstacles=drv.geom.obstacles, sigma=self._sigma_xy())
        start = self.filter.pose
        newest = idx[-1]
        last = drv.units[newest].span.last
        attempts = [(regions, perceived)]
        if any(perceived):
            # If what PERCEPTION reported leaves no way to the far edge (a partial or misplaced
            # region), plan on the map's regions for these units instead.
            attempts.append(([drv.units[i].span.region for i in idx], [False] * len(idx)))
        for k, (regs, flags) in enumerate(attempts):
            try:
                cons = local_constraints(drv.geom.path, regs, far_s, flags, **kw)
                if last and k < len(attempts) - 1 and not drv.goal_meets_exit(cons.goals[-1], float(cons.goal_s[-1])):
                    # A perceived region that ends short of the segment's exit would leave the vehicle
                    # standing before it: the map's region reaches the exit.
                    raise ConstraintError(f"the last goal at s={cons.goal_s[-1]:.1f} m falls short of the exit")
                # Goals moved back (obstacles, region ends) may now lie behind the vehicle: skip those.
                goals = [g for g, s in zip(cons.goals, cons.goal_s) if s > drv.s_vehicle + self.cfg.min_goal_ahead_m] or [cons.goals[-1]]
                path = await asyncio.to_thread(self.planner.plan, start, goals, cons.region)
                regions = regs
                break
            except (ConstraintError, PlanningError) as exc:
                if k == len(attempts) - 1:
                    raise
                log.warning("pilot: perceived regions unusable (%s); planning on the map's", exc)
        stop_here = last and seg.constraints.stop_at_exit
        # Only a segment that must stop at its exit ends in a stop; otherwise the HELM brakes to the
        # plan's end by itself unless the next plan (or the next segment's) arrives first.
        v = speed_profile(path.s, path.curvature, path.direction, speed_limit, stop_at_end=stop_here, cfg=self.cfg.speed)
        # World → local for the HELM: local←world = (world←local)⁻¹ at the current odometry.
        local_world = inverse(self.filter.world_from_local(self.odom.pose))
        xy = transform_points(local_world, path.poses[:, :2])
        yaw = path.poses[:, 2] + local_world[2]
        now = self.rt.clock.now()
        track = tuple((float(x), float(y)) for x, y in cons.goals[:, :2]) if len(cons.goals) > 1 else (
            (float(start[0]), float(start[1])), (float(cons.goals[-1][0]), float(cons.goals[-1][1])))
        region_ring = as_ring(shapely.union_all(regions))
        lpc = LocalPathConstraints(
            unit_id=unit_ids.get(newest, f"{seg.segment_id}.u{newest}"), segment_id=seg.segment_id, frame="world",
            region=region_ring, track=track, margin_m=self.cfg.navigator.margin, speed_limit=speed_limit, stop_at_end=stop_here,
        )
        await self.bb.post(lpc, frame="world", geometry=BbPolygon(points=region_ring), stamp=now)
        self.plan_seq += 1
        poses = tuple(
            PlanPose(x=float(px), y=float(py), yaw=float(math.atan2(math.sin(a), math.cos(a))), speed=float(sp))
            for (px, py), a, sp in zip(xy, yaw, v)
        )
        plan = LocalPathPlan(
            seq=self.plan_seq, segment_id=seg.segment_id, unit_ids=tuple(unit_ids[i] for i in idx if i in unit_ids),
            frame="local", poses=poses, stop_at_end=stop_here,
        )
        await self.bb.post(plan, frame="local", geometry=BbPolyline(points=tuple((p.x, p.y) for p in poses)), stamp=now)
        drv.mark_planned(newest, float(cons.goal_s[-1]))
        self._last_plan_t = now
        self.stats["plans"] += 1

    async def _report(self, seg: RouteSegmentDescription, success: bool, reason: str, start_distance: float | None = None) -> None:
        self._done_segments.add(seg.segment_id)
        p = self.filter.pose if self.filter is not None else None
        dist = (self.filter.distance_m - start_distance) if (self.filter is not None and start_distance is not None) else 0.0
        res = SegmentResult(
            segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=seg.segment_index, success=success,
            reason=reason, end_xy=None if p is None else (float(p[0]), float(p[1])), distance_m=max(0.0, dist),
        )
        log.info("pilot: segment %s %s: %s", seg.segment_id, "done" if success else "FAILED", reason)
        await self.bb.post(res, frame="world", geometry=None, stamp=self.rt.clock.now())
