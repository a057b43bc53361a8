"""DRIVING UNIT FINDER (seed: Sidewalk §2.3.3): the PILOT's interface to PERCEPTION.

The driving units the DRIVING MONITOR posts reach PERCEPTION through the blackboard; the finder
collects PERCEPTION's answers — `perception_result` tokens, one per unit — and resolves each unit
with the navigable region PERCEPTION saw (brought to `world`, fused with the map's outside the
view frame), handing position fixes to the POSITION ESTIMATOR. Units PERCEPTION does not answer
in time fall back to the map; in `auto` mode repeated silence switches the PILOT to dead
reckoning until PERCEPTION answers again. Times are sim time [s].
"""

from __future__ import annotations

import asyncio
import logging

import numpy as np
from shapely.geometry import Polygon as ShPolygon

from blackboard.errors import BlackboardError
from modules.pilot.config import PilotConfig
from codger.pilot.position_estimator import PositionEstimator
from modules.pilot.segment import SegmentDriver, fuse_regions
from modules.vocabulary import PerceptionResult, RouteSegmentDescription

__all__ = ["DrivingUnitFinder"]

log = logging.getLogger("codger.pilot")


class DrivingUnitFinder:
    """Resolve driving units from PERCEPTION's results (or its silence); feed fixes to the estimator."""

    def __init__(self, bb, cfg: PilotConfig, estimator: PositionEstimator) -> None:
        """Hold the blackboard client and the POSITION ESTIMATOR; start in dead reckoning if PERCEPTION is off."""
        self.bb = bb
        self.cfg = cfg
        self.estimator = estimator
        #: monitor events of `perception_result` tokens
        self.events: asyncio.Queue = asyncio.Queue()
        self.misses = 0
        self.dead_reckoning = cfg.perception == "off"

    async def collect(self, seg: RouteSegmentDescription, drv: SegmentDriver, unit_index: dict[str, int]) -> str | None:
        """Resolve the segment's units PERCEPTION answered since the last call; return the unit whose fix was used last."""
        fixed_unit = None
        while not self.events.empty():
            ev = self.events.get_nowait()
            res = ev.token.attrs
            if ev.kind == "deleted" or not isinstance(res, PerceptionResult) or res.segment_id != seg.segment_id or res.unit_id not in unit_index:
                continue
            i = unit_index[res.unit_id]
            if drv.units[i].phase == "resolved" and (drv.units[i].perceived or res.status != "perceived"):
                continue
            region = await self._region_in_world(res, drv.units[i].span.region) if res.status == "perceived" else None
            if res.status == "perceived" and await self.estimator.apply_fix(res):
                fixed_unit = res.unit_id
            if drv.units[i].phase != "resolved" or region is not None:
                drv.resolve(i, region, res.status == "perceived", f"perception {res.status}", sensed_at=res.captured_at)
                drv.planned_through = min(drv.planned_through, i - 1)  # a late region still reshapes the plan
            self.misses = 0
            if self.dead_reckoning and self.cfg.perception == "auto":
                log.info("pilot: PERCEPTION answered again: leaving dead reckoning")
                self.dead_reckoning = False
                drv.use_perception = True
        return fixed_unit

    def time_out(self, drv: SegmentDriver, now: float) -> None:
        """Give the units PERCEPTION left unanswered past the timeout the map's region; count the misses."""
        cfg = self.cfg
        for i in drv.overdue(now):
            drv.resolve(i, None, False, "perception timeout")
            self.misses += 1
            if cfg.perception == "auto" and self.misses >= cfg.max_perception_misses and not self.dead_reckoning:
                log.warning("pilot: no PERCEPTION result for %d units: dead reckoning on the map", self.misses)
                self.dead_reckoning = True
                drv.use_perception = False

    def skip(self, drv: SegmentDriver, posted: list[int]) -> None:
        """Resolve just-posted units from the map at once while PERCEPTION is not used."""
        if not drv.use_perception:
            for i in posted:
                drv.resolve(i, None, False, "dead reckoning")

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
