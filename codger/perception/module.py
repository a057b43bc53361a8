"""The PERCEPTION process: one driving unit at a time, from the blackboard to the simulator's sensors and back.

Seed: Sidewalk 1986 §2.3.5 and §3.3. For each pending driving unit the PERCEPTION MONITOR picks the
segmentation and the view frame, finds the image input position by running the view frame along the
newest local path plan, waits until the moving vehicle position (local←vehicle) reaches it, asks the
simulator's capture queryable for an image (images never go through the blackboard), runs the PATCH
MAKER, OBJECT FINDER and POSITION CALIBRATOR, posts the result once as a `perception_result` token
(perceived or failed, with the reason) and then sets the driving unit's status to match.

Blackboard contract:
  reads   driving_unit (status "pending"), local_path_plan (newest), poses local←vehicle, world←local
  writes  perception_result (frame world), then driving_unit.status only (CAS update)
  asks    sidewalk/<ns>/sim/capture (CaptureRequest JSON → `sidewalk.capture/1` msgpack)
"""

from __future__ import annotations

import asyncio
import json
import logging
import time
from dataclasses import dataclass, field

import numpy as np
import shapely.errors
from pydantic import BaseModel, ConfigDict, Field
from shapely.geometry import Polygon as ShapelyPolygon

from blackboard import AttrPredicate, BlackboardError, Polygon as BbPolygon, Spec, VersionConflictError, NotFoundError
from blackboard.errors import FutureExtrapolationError
from modules.parallel import VisionPool
from modules.perception.monitor import SENSORS, ResolutionTable, SensorGeometry, image_input_position
from modules.perception.pipeline import PerceptionPipeline
from modules.perception.results import build_result, failed_result
from modules.perception.road_method import RoadMethodPerception
from modules.road_following import RoadFollowingError
from wire.keys import SimKeys
from modules.perception.sensor_frame import SensorFrameError, colored_range_image, decode_sensor_frame, sensor_geometry
from modules.vocabulary import DrivingUnitDescription, LocalPathPlan, PerceptionResult

__all__ = ["PerceptionConfig", "PerceptionModule", "CycleStats", "SENSORS", "capture_key"]

log = logging.getLogger("codger.perception")

#: Laser mounting per vehicle (height [m], ahead of the vehicle origin [m]): the view table's first guess,
#: replaced by the calibration the first capture carries.


def capture_key(namespace: str) -> str:
    """Return the simulator's capture queryable key in a namespace."""
    return SimKeys(namespace).capture


class PerceptionConfig(BaseModel):
    """PERCEPTION process settings: vehicle (sensor geometry), speed for the view table, timing [s] sim."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    vehicle: str = Field("terregator", pattern="^(navlab|terregator)$")
    speed: float = Field(1.0, gt=0.0, description="desired vehicle speed for the view/resolution table [m/s]")
    tick_s: float = Field(0.1, gt=0.0, description="how often the moving vehicle position is checked [s] sim")
    max_wait_s: float = Field(6.0, gt=0.0, description="longest wait for the image input position [s] sim")
    capture_timeout_s: float = Field(5.0, gt=0.0, description="capture query timeout [s] wall")
    reach_tolerance_m: float = Field(0.3, ge=0.0, description="capture this close before the input position [m]")
    pose_wait_s: float = Field(1.0, ge=0.0, description="longest wait for the vehicle pose at capture time to arrive [s] sim")
    road_method: str = Field("perception", pattern="^(perception|scarf|yarf|alvinn)$",
                             description="issue 13: what finds the road of follow-road units (a road follower replaces the navigable region)")
    vision_workers: int = Field(1, ge=1, le=64, description="issue 41: processes the per-pixel stages run on (1: this process alone)")


@dataclass
class CycleStats:
    """Wall times [s] of the cycles: capture query and processing (decode to result written)."""

    capture_s: list[float] = field(default_factory=list)
    process_s: list[float] = field(default_factory=list)
    perceived: int = 0
    failed: int = 0


def _arc_length(path: np.ndarray, xy: np.ndarray) -> float:
    seg = np.diff(path, axis=0)
    ln = np.maximum(np.linalg.norm(seg, axis=1), 1e-12)
    t = np.clip(((xy - path[:-1]) * seg).sum(1) / ln**2, 0.0, 1.0)
    proj = path[:-1] + t[:, None] * seg
    i = int(np.argmin(np.linalg.norm(proj - xy, axis=1)))
    return float(np.concatenate([[0.0], np.cumsum(ln)])[i] + t[i] * ln[i])


class PerceptionModule:
    """The PERCEPTION process body: `await PerceptionModule(rt, cfg).run()` inside `run_module`."""

    def __init__(self, rt, cfg: PerceptionConfig = PerceptionConfig(), *, road: RoadMethodPerception | None = None) -> None:
        """Bind to a module runtime (blackboard client, Zenoh link, sim clock); `road`: the road follower of follow-road units."""
        self.rt = rt
        self.cfg = cfg
        self.bb = rt.bb
        pool = VisionPool(cfg.vision_workers, warm=("modules.perception",)) if cfg.vision_workers > 1 else None  # issue 41
        self.pipeline = PerceptionPipeline(ResolutionTable(SENSORS[cfg.vehicle]), speed=cfg.speed, pool=pool)
        self.stats = CycleStats()
        self.road = road  # issue 13
        self._queue: asyncio.Queue = asyncio.Queue()
        self._queued: set[str] = set()

    # ---- the loop ------------------------------------------------------------------------------
    async def run(self) -> None:
        """Serve pending driving units one at a time until the runtime stops."""
        await self.rt.clock.wait_running()
        pending = Spec(type="driving_unit", where=(AttrPredicate(path="status", op="==", value="pending"),))
        mon = await self.bb.monitor(pending).start()
        pump = asyncio.ensure_future(self._pump(mon))
        try:
            for tok in sorted(await self.bb.retrieve(pending), key=lambda t: (t.stamp, t.attrs.unit_index)):
                self._enqueue(tok)
            self.rt.ready()
            while not self.rt.stopping:
                tok = await self._queue.get()
                self._queued.discard(tok.id)
                current = await self._current(tok)
                if current is None:
                    continue
                try:
                    await self.handle(current)
                except BlackboardError as exc:
                    log.warning("perception: %s: blackboard error: %s", current.attrs.unit_id, exc)
                except Exception as exc:  # one unit's fault never takes PERCEPTION down: the unit fails, saying why
                    log.exception("perception: %s: unexpected error", current.attrs.unit_id)
                    reason = f"perception error: {type(exc).__name__}: {exc}"[:500]
                    try:
                        await self._write(current, failed_result(current.attrs, reason, self.rt.clock.now_or(0.0)))
                    except BlackboardError as exc2:
                        log.warning("perception: cannot report the failure of %s: %s", current.attrs.unit_id, exc2)
        finally:
            pump.cancel()
            await mon.close()
            if self.pipeline.pool is not None:
                self.pipeline.pool.close()

    def _enqueue(self, tok) -> None:
        if tok.id not in self._queued and tok.attrs.status == "pending":
            self._queued.add(tok.id)
            self._queue.put_nowait(tok)

    async def _pump(self, mon) -> None:
        async for ev in mon:
            if ev.kind in ("new", "updated"):
                self._enqueue(ev.token)

    async def _current(self, tok):
        try:
            toks = await self.bb.retrieve(Spec(type="driving_unit", where=(AttrPredicate(path="unit_id", op="==", value=tok.attrs.unit_id),)))
        except BlackboardError as exc:
            log.warning("perception: cannot re-read %s: %s", tok.attrs.unit_id, exc)
            return tok
        toks = [t for t in toks if t.id == tok.id]
        if not toks or toks[0].attrs.status != "pending":
            return None  # cancelled or answered meanwhile
        return toks[0]

    # ---- one driving unit ----------------------------------------------------------------------
    async def handle(self, tok) -> PerceptionResult:
        """See, find and fix for one driving unit; post the result, set the unit's status; return the result."""
        unit: DrivingUnitDescription = tok.attrs
        plan = self.pipeline.table.plan(unit.error_allowance_m, self.cfg.speed)
        note = await self.wait_for_input_position(unit, plan.view_frame)
        t0 = time.perf_counter()
        try:
            payload = await self._capture()
        except (TimeoutError, RuntimeError) as exc:
            return await self._write(tok, failed_result(unit, f"capture failed: {exc}", self.rt.clock.now_or(0.0)))
        t1 = time.perf_counter()
        try:
            frame = decode_sensor_frame(payload)
        except SensorFrameError as exc:
            return await self._write(tok, failed_result(unit, f"bad capture: {exc}", self.rt.clock.now_or(0.0)))
        try:
            p = await self._pose_at(frame.stamp)
        except BlackboardError as exc:
            return await self._write(tok, failed_result(unit, f"no vehicle pose at capture time {frame.stamp:.2f} s: {exc}", frame.stamp))
        prior = (p.x, p.y, p.yaw)
        geom = sensor_geometry(frame)
        if geom != self.pipeline.table.sensor:
            self.pipeline.table.sensor = geom  # the capture's own calibration wins over the preset
        try:
            img = colored_range_image(frame, pool=self.pipeline.pool)
            out = self.pipeline.process(img, unit.objects, prior, error_allowance=max(unit.error_allowance_m, 0.2))
            if self.road is not None and unit.mode == "follow-road":  # issue 13: the road follower's road
                try:
                    out = self.road.replace_navigable(out, self.road.observe(unit, frame, prior))
                except RoadFollowingError as exc:
                    return await self._write(tok, failed_result(unit, f"{self.cfg.road_method}: {exc}"[:500], frame.stamp))
            res = build_result(unit, out, prior, frame.stamp, img)
        except (ValueError, ArithmeticError, IndexError, np.linalg.LinAlgError, shapely.errors.ShapelyError) as exc:
            log.exception("perception: %s: processing failed", unit.unit_id)
            return await self._write(tok, failed_result(unit, f"processing failed: {type(exc).__name__}: {exc}"[:500], frame.stamp))
        dt = time.perf_counter() - t1
        res = res.model_copy(update={"processing_s": dt})
        self.stats.capture_s.append(t1 - t0)
        self.stats.process_s.append(dt)
        if note:
            log.info("perception: %s: %s", unit.unit_id, note)
        return await self._write(tok, res)

    async def _pose_at(self, stamp: float):
        """Return world←vehicle at sim time `stamp` [s], waiting up to `pose_wait_s` for the HELM's pose to catch up.

        The capture is stamped by the simulator; the moving vehicle position reaches the blackboard a
        publish period later, so a look-up right after the capture may be a little in the future.
        """
        deadline = self.rt.clock.now() + self.cfg.pose_wait_s
        while True:
            try:
                return await self.bb.lookup_pose(parent="world", child="vehicle", stamp=stamp)
            except FutureExtrapolationError:
                if self.rt.stopping or self.rt.clock.now() >= deadline:
                    raise
            await self.rt.clock.sleep(self.cfg.tick_s)

    async def wait_for_input_position(self, unit: DrivingUnitDescription, view_frame) -> str:
        """Simulate the view frame along the newest local path plan and wait until the vehicle reaches the input position.

        Without any plan yet the vehicle is standing still for this unit, so the image is taken at once;
        otherwise waits at most `max_wait_s` [s] sim. Returns a note when the image is taken without
        reaching the position (no plan, no pose, timeout), "" when it was reached.
        """
        start = self.rt.clock.now()
        deadline = start + self.cfg.max_wait_s
        target = None
        seq = None
        why = "no local path plan"
        while not self.rt.stopping:
            try:
                plans = await self.bb.retrieve(Spec(type="local_path_plan", newest=True))
                if not plans and target is None:
                    return "no local path plan yet (nothing moves before this unit is seen); capturing now"
                if plans and plans[0].attrs.seq != seq:
                    lp: LocalPathPlan = plans[0].attrs
                    seq = lp.seq
                    path = np.array([(q.x, q.y) for q in lp.poses], dtype=np.float64)
                    region = np.asarray(unit.region, dtype=np.float64)
                    if lp.frame != "world":
                        now = self.rt.clock.now()
                        region = await self.bb.transform(region, src_frame="world", src_stamp=now, dst_frame=lp.frame, dst_stamp=now)
                    if np.linalg.norm(np.diff(path, axis=0), axis=1).sum() >= 0.1:
                        target = (lp.frame, path, image_input_position(path, ShapelyPolygon(region), view_frame))
                if target is not None:
                    frame, path, pos = target
                    v = await self.bb.lookup_pose(parent=frame, child="vehicle", stamp=None)
                    s = _arc_length(path, np.array([v.x, v.y]))
                    if s >= pos.arc_length - self.cfg.reach_tolerance_m:
                        return ""
                    why = f"input position {pos.arc_length:.1f} m along the plan not reached (vehicle at {s:.1f} m)"
            except BlackboardError as exc:
                why = f"{why} ({type(exc).__name__}: {exc})"
            if self.rt.clock.now() >= deadline:
                return f"{why} after {self.cfg.max_wait_s:.0f} s; capturing now"
            await self.rt.clock.sleep(self.cfg.tick_s)
        return "stopping"

    async def _capture(self) -> bytes:
        req = json.dumps({"laser": True, "camera": True}).encode()
        replies = await self.rt.link.get(capture_key(self.rt.net.namespace), payload=req, timeout=self.cfg.capture_timeout_s)
        for r in replies:
            if r.ok:
                return r.payload
        if replies:
            raise RuntimeError(replies[0].payload.decode(errors="replace")[:200])
        raise TimeoutError(f"no simulator answered {capture_key(self.rt.net.namespace)} within {self.cfg.capture_timeout_s:.1f} s")

    async def _write(self, tok, res: PerceptionResult) -> PerceptionResult:
        """Post the result as its own token, then set the driving unit's status (CAS, re-read on conflict)."""
        if res.status == "perceived":
            self.stats.perceived += 1
        else:
            self.stats.failed += 1
            log.warning("perception: %s failed: %s", res.unit_id, res.failure_reason)
        stamp = self.rt.clock.now_or(res.captured_at)
        geom = None
        if res.navigable_region:
            try:
                geom = BbPolygon(points=res.navigable_region)
            except ValueError as exc:  # the result stands without its spatial index entry
                log.warning("perception: %s: navigable region not indexed: %s", res.unit_id, exc)
        try:
            await self.bb.post(res, frame="world", geometry=geom, stamp=stamp)
        except BlackboardError as exc:
            log.warning("perception: posting the result of %s failed: %s", res.unit_id, exc)
        for _ in range(3):
            try:
                await self.bb.update(tok.id, tok.attrs.model_copy(update={"status": res.status}), expected_version=tok.version)
                break
            except VersionConflictError:
                cur = await self._current(tok)
                if cur is None:
                    break  # cancelled meanwhile: the posted result stands on its own
                tok = cur
            except NotFoundError:
                break
            except BlackboardError as exc:
                log.warning("perception: setting the status of %s failed: %s", res.unit_id, exc)
                break
        return res
