"""DRIVING MONITOR (seed: Sidewalk §2.3.3): the top of the PILOT; route segments in, driving units out.

Receives route segment descriptions from the blackboard (one active at a time; a newer one
pre-empts, a cancelled one stops), breaks the segment into driving units (`driving_units`,
`segment`), posts a driving unit description — where and what to see, never how — for each unit
as it comes within the look-ahead, and posts the segment's result. Geometry is `world` [m];
times are sim time [s].
"""

from __future__ import annotations

import asyncio
import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from shapely.geometry import Point
from shapely.geometry import Polygon as ShPolygon

from blackboard import AttrPredicate, Spec
from blackboard import Polygon as BbPolygon
from blackboard.errors import BlackboardError
from modules.pilot.config import PilotConfig
from modules.pilot.driving_units import ExpectedObject
from modules.pilot.polyline import PathLine
from codger.pilot.position_estimator import PositionEstimator
from modules.pilot.segment import SegmentDriver, SegmentGeometry, as_ring, map_region
from modules.vocabulary import DrivingUnitDescription, MapObject, RouteSegmentDescription, SegmentResult

__all__ = ["DrivingMonitor", "SegmentChange", "segment_geometry", "object_geometry"]

log = logging.getLogger("codger.pilot")


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


@dataclass(frozen=True)
class SegmentChange:
    """What happened to the segment being driven: `cancelled`, or `superseded` by the newer segment token `by`."""

    kind: str
    by: Any = None


class DrivingMonitor:
    """Receive route segments, post driving units ahead of the vehicle, post segment results."""

    def __init__(self, bb, clock, cfg: PilotConfig, estimator: PositionEstimator) -> None:
        """Hold the blackboard client, the sim clock and the POSITION ESTIMATOR (for the error allowance)."""
        self.bb = bb
        self.clock = clock
        self.cfg = cfg
        self.estimator = estimator
        self.events: asyncio.Queue = asyncio.Queue()
        self.done: set[str] = set()
        self.units_posted = 0
        #: the current segment's posted units: index → unit id, unit id → index
        self.unit_ids: dict[int, str] = {}
        self.unit_index: dict[str, int] = {}

    # -- route segments ------------------------------------------------------------------------
    async def resume_candidate(self):
        """Return an active segment token nobody reported on yet (the PILOT restarted mid-segment), or None."""
        try:
            toks = await self.bb.retrieve(Spec(type="route_segment", where=(AttrPredicate(path="state", op="==", value="active"),), newest=True))
        except BlackboardError as exc:
            log.warning("pilot: cannot look for an active segment: %s", exc)
            return None
        for t in toks:
            done = await self.bb.retrieve(Spec(type="segment_result", where=(AttrPredicate(path="segment_id", op="==", value=t.attrs.segment_id),)))
            if not done:
                return t
            self.done.add(t.attrs.segment_id)
        return None

    async def next_segment(self, timeout_s: float):
        """Return the next active segment token announced within `timeout_s` [s] sim, or None."""
        ev = await self.clock.wait_for(self.events.get(), timeout_s)
        seg = ev.token.attrs
        if ev.kind == "deleted" or seg.state != "active" or seg.segment_id in self.done:
            return None
        return ev.token

    def begin(self, seg: RouteSegmentDescription, use_perception: bool) -> SegmentDriver:
        """Break segment `seg` into driving units; raise PolylineError or ValueError on bad geometry."""
        cfg = self.cfg
        geom = segment_geometry(seg, cfg.region_extension_m)
        self.unit_ids, self.unit_index = {}, {}
        return SegmentDriver(geom, cfg.units, cfg.lookahead_m, cfg.perception_timeout_s, use_perception)

    async def change(self, seg: RouteSegmentDescription) -> SegmentChange | None:
        """Return whether segment `seg` was withdrawn or superseded since the last look (its units then cancelled)."""
        while not self.events.empty():
            ev = self.events.get_nowait()
            other = ev.token.attrs
            if other.segment_id == seg.segment_id:
                if ev.kind == "deleted" or other.state == "cancelled":
                    log.info("pilot: segment %s cancelled", seg.segment_id)
                    await self.cancel_units()
                    return SegmentChange("cancelled")
            elif ev.kind != "deleted" and other.state == "active" and other.segment_id not in self.done:
                # The MAP NAVIGATOR has moved on (one segment at a time): follow it, report nothing.
                log.info("pilot: segment %s superseded by %s", seg.segment_id, other.segment_id)
                self.done.add(seg.segment_id)
                await self.cancel_units()
                return SegmentChange("superseded", ev.token)
        return None

    # -- driving units -------------------------------------------------------------------------
    async def post_units(self, seg: RouteSegmentDescription, drv: SegmentDriver, now: float) -> list[int]:
        """Post the driving units due now (look-ahead, one in flight to PERCEPTION); return their indices."""
        posted = []
        for i in drv.units_to_post(now):
            tok = await self._post_unit(seg, drv, i)
            self.unit_ids[i] = tok.attrs.unit_id
            self.unit_index[tok.attrs.unit_id] = i
            posted.append(i)
        return posted

    async def _post_unit(self, seg: RouteSegmentDescription, drv: SegmentDriver, i: int):
        span = drv.units[i].span
        ring = as_ring(span.region)
        cov = self.estimator.cov
        sd = math.sqrt(max(cov[0, 0], cov[1, 1]))
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
            heading_allowance_rad=float(3.0 * math.sqrt(cov[2, 2])),
        )
        self.units_posted += 1
        return await self.bb.post(du, frame="world", geometry=BbPolygon(points=ring), stamp=self.clock.now())

    async def cancel_units(self) -> None:
        """Mark the current segment's driving units still pending as cancelled."""
        for uid in self.unit_ids.values():
            try:
                toks = await self.bb.retrieve(Spec(type="driving_unit", where=(AttrPredicate(path="unit_id", op="==", value=uid),
                                                                             AttrPredicate(path="status", op="==", value="pending"))))
                for t in toks:
                    await self.bb.update(t.id, t.attrs.model_copy(update={"status": "cancelled"}), expected_version=t.version)
            except BlackboardError as exc:
                log.info("pilot: could not cancel %s: %s", uid, exc)

    # -- results -------------------------------------------------------------------------------
    async def report(self, seg: RouteSegmentDescription, success: bool, reason: str, start_distance: float | None = None) -> None:
        """Post the segment's result: success, why, where the estimate ends (world), distance driven [m]."""
        self.done.add(seg.segment_id)
        est = self.estimator
        p = est.pose if est.started else None
        dist = (est.distance_m - start_distance) if (est.started and start_distance is not None) else 0.0
        res = SegmentResult(
            segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=seg.segment_index, success=success,
            reason=reason, end_xy=None if p is None else (float(p[0]), float(p[1])), distance_m=max(0.0, dist),
        )
        log.info("pilot: segment %s %s: %s", seg.segment_id, "done" if success else "FAILED", reason)
        await self.bb.post(res, frame="world", geometry=None, stamp=self.clock.now())
