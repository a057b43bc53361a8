"""DRIVING UNIT NAVIGATOR (seed: Sidewalk §2.3.3): local path constraints in the driving units ahead.

Plots the local path constraints from PERCEPTION's regions (the map's where PERCEPTION did not
see) and the driving constraints the MAP NAVIGATOR gave the segment (keep right/left, lateral
offset, speed limit), with `local_path_constraints.local_constraints` as its core, and posts them as a
`local_path_constraints` token. Geometry is `world` [m].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from blackboard import Polygon as BbPolygon
from modules.pilot.config import PilotConfig
from modules.pilot.local_path_constraints import ConstraintError, LocalConstraints, local_constraints
from modules.pilot.segment import SegmentDriver, as_ring
from modules.vocabulary import LocalPathConstraints, RouteSegmentDescription

__all__ = ["DrivingUnitNavigator", "UnitConstraints"]


@dataclass(frozen=True)
class UnitConstraints:
    """One set of constraints over the units `indices`: the unit regions used (world), the core's constraints, the goals ahead."""

    indices: tuple[int, ...]
    regions: tuple[BaseGeometry, ...]
    constraints: LocalConstraints
    goals: tuple[np.ndarray, ...]


class DrivingUnitNavigator:
    """Build local path constraints over the resolved driving units; post the ones the plan used."""

    def __init__(self, bb, cfg: PilotConfig) -> None:
        """Hold the blackboard client and the PILOT's configuration."""
        self.bb = bb
        self.cfg = cfg

    def speed_limit(self, seg: RouteSegmentDescription) -> float:
        """Return the segment's speed limit [m/s] (the PILOT's maximum when the segment sets none)."""
        return min(self.cfg.max_speed, seg.constraints.speed_limit or self.cfg.max_speed)

    def alternatives(self, drv: SegmentDriver) -> list[tuple[tuple[BaseGeometry, ...], tuple[bool, ...]]]:
        """Return the unit regions to try, in order: as resolved (PERCEPTION's where it saw), then the map's alone."""
        regions, _, perceived, idx = drv.plan_inputs()
        out = [(tuple(regions), tuple(perceived))]
        if any(perceived):
            # If what PERCEPTION reported leaves no way to the far edge (a partial or misplaced
            # region), plan on the map's regions for these units instead.
            out.append((tuple(drv.units[i].span.region for i in idx), (False,) * len(idx)))
        return out

    def constrain(self, seg: RouteSegmentDescription, drv: SegmentDriver, regions, perceived, *, sigma: float,
                  must_reach_exit: bool) -> UnitConstraints:
        """Return the constraints over `regions` (world) with the goals still ahead; raise ConstraintError.

        `sigma` [m] is the position estimate's standard deviation (it widens obstacle clearance);
        with `must_reach_exit`, a last unit whose goal falls short of the exit is refused.
        """
        _, far_s, _, idx = drv.plan_inputs()
        c = seg.constraints
        offset = c.lateral_offset_m if (c.keep is not None and c.lateral_offset_m != 0.0) else None
        cons = local_constraints(drv.geom.path, list(regions), far_s, list(perceived), keep=c.keep or "none",
                                 cfg=self.cfg.navigator, lateral_offset=offset, obstacles=drv.geom.obstacles, sigma=sigma)
        if must_reach_exit and drv.units[idx[-1]].span.last and not drv.goal_meets_exit(cons.goals[-1], float(cons.goal_s[-1])):
            # A perceived region that ends short of the segment's exit would leave the vehicle
            # standing before it: the map's region reaches the exit.
            raise ConstraintError(f"the last goal at s={cons.goal_s[-1]:.1f} m falls short of the exit")
        # Goals moved back (obstacles, region ends) may now lie behind the vehicle: skip those.
        goals = [g for g, s in zip(cons.goals, cons.goal_s) if s > drv.s_vehicle + self.cfg.min_goal_ahead_m] or [cons.goals[-1]]
        return UnitConstraints(indices=tuple(idx), regions=tuple(regions), constraints=cons, goals=tuple(goals))

    async def post(self, seg: RouteSegmentDescription, uc: UnitConstraints, start: np.ndarray, unit_id: str,
                   speed_limit: float, stop_at_end: bool, now: float) -> LocalPathConstraints:
        """Post the constraints a plan from `start` (world pose (3,)) used, stamped `now` [s]."""
        cons = uc.constraints
        track = tuple((float(x), float(y)) for x, y in cons.goals[:, :2]) if len(cons.goals) > 1 else (
            (float(start[0]), float(start[1])), (float(cons.goals[-1][0]), float(cons.goals[-1][1])))
        region_ring = as_ring(shapely.union_all(uc.regions))
        lpc = LocalPathConstraints(
            unit_id=unit_id, segment_id=seg.segment_id, frame="world", region=region_ring, track=track,
            margin_m=self.cfg.navigator.margin, speed_limit=speed_limit, stop_at_end=stop_at_end,
        )
        await self.bb.post(lpc, frame="world", geometry=BbPolygon(points=region_ring), stamp=now)
        return lpc
