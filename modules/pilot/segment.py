"""PILOT segment core: the Figure 6 pipeline over one route segment, as plain state on data.

Frame: `world` [m]. The DRIVING MONITOR posts driving unit k only once unit k-1 is resolved
(perceived, failed, or given up on), and only while it lies within the look-ahead distance of the
vehicle; each resolution lets the LOCAL PATH PLANNER extend the plan from the vehicle's pose
through all resolved driving units to the far edge of the newest — while the vehicle drives the
earlier ones. Without PERCEPTION every unit is resolved at once from the map (dead reckoning).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import shapely
from shapely.geometry import LineString
from shapely.geometry.base import BaseGeometry

from modules.pilot.driving_units import DrivingUnitConfig, DrivingUnitSpan, ExpectedObject, split_segment
from modules.pilot.polyline import PathLine

__all__ = ["SegmentGeometry", "UnitState", "SegmentDriver", "map_region", "as_ring", "fuse_regions"]

UnitPhase = Literal["new", "posted", "resolved"]


@dataclass(frozen=True)
class SegmentGeometry:
    """What the PILOT takes from a route segment description: centreline, map region, objects, exit (world)."""

    path: PathLine
    region: BaseGeometry
    objects: tuple[ExpectedObject, ...]
    exit_point: tuple[float, float]
    exit_radius: float
    obstacles: tuple[BaseGeometry, ...] = ()


@dataclass
class UnitState:
    """Pipeline state of one driving unit: phase, the region used for planning, how it was resolved."""

    span: DrivingUnitSpan
    phase: UnitPhase = "new"
    posted_at: float | None = None
    region: BaseGeometry | None = None
    perceived: bool = False
    how: str = ""
    #: capture stamp [s sim] of PERCEPTION's result that resolved the unit (None: not perceived)
    sensed_at: float | None = None


def map_region(centreline: np.ndarray, width: float, path_polygons: list[BaseGeometry], obstacles: list[BaseGeometry] = ()) -> BaseGeometry:
    """Return the navigable region from the map: path objects ∪ centreline corridor, minus obstacles (world).

    Standing objects are better given to the navigator (it keeps a clearance from them); the ones
    passed here are only cut out of the region as they are.
    """
    corridor = LineString(centreline).buffer(width / 2.0)
    region = shapely.union_all([corridor, *path_polygons]) if path_polygons else corridor
    # Keep only path-object area near the centreline (a whole sidewalk polygon can be very long).
    region = shapely.intersection(region, LineString(centreline).buffer(max(width, 2.0) * 1.5 + 3.0))
    if obstacles:
        region = shapely.difference(region, shapely.union_all(obstacles))
    return region


def fuse_regions(perceived: BaseGeometry, view_frame: BaseGeometry | None, map_unit: BaseGeometry) -> BaseGeometry:
    """Return a unit's navigable region: PERCEPTION's inside its view frame, the map's outside it (world).

    PERCEPTION only reports what its sensor saw; the part of the unit it did not look at keeps the
    map's region, so the far edge of the unit stays reachable. Without a view frame, the map fills
    in only what lies beyond the perceived region's reach of the unit.
    """
    if perceived.is_empty:
        return map_unit
    if view_frame is not None and not view_frame.is_empty:
        return shapely.union(perceived, shapely.difference(map_unit, view_frame))
    return shapely.union(perceived, shapely.difference(map_unit, perceived.convex_hull))


def as_ring(geom: BaseGeometry) -> tuple[tuple[float, float], ...]:
    """Return the exterior ring (≥3 vertices, no repeat) of a region's largest polygon (world [m])."""
    if geom.geom_type == "Polygon":
        poly = geom
    else:
        polys = [g for g in getattr(geom, "geoms", []) if g.geom_type == "Polygon" and not g.is_empty]
        poly = max(polys, key=lambda g: g.area) if polys else geom.convex_hull
    if poly.is_empty or poly.geom_type != "Polygon":
        poly = geom.buffer(0.1).convex_hull
    coords = [(float(x), float(y)) for x, y in poly.exterior.coords[:-1]]
    return tuple(coords)


@dataclass
class SegmentDriver:
    """Drive one segment's pipeline: which units to post, which to resolve, what to plan, when done."""

    geom: SegmentGeometry
    unit_cfg: DrivingUnitConfig = field(default_factory=DrivingUnitConfig)
    lookahead_m: float = 14.0
    perception_timeout_s: float = 8.0
    use_perception: bool = True
    units: list[UnitState] = field(init=False)
    s_vehicle: float = field(init=False, default=0.0)
    planned_through: int = field(init=False, default=-1)
    final_goal_s: float | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        self.units = [UnitState(span=u) for u in split_segment(self.geom.path, self.geom.region, self.geom.objects, self.unit_cfg)]

    # -- progress -------------------------------------------------------------------------------
    def update_progress(self, xy: np.ndarray) -> float:
        """Project the vehicle's world position onto the path; progress never runs backwards [m]."""
        s, _ = self.geom.path.project(xy)
        self.s_vehicle = max(self.s_vehicle, s) if abs(s - self.s_vehicle) < 10.0 else s
        return self.s_vehicle

    def current_index(self) -> int:
        """Return the index of the driving unit the vehicle is in."""
        for i, u in enumerate(self.units):
            if self.s_vehicle < u.span.s_end:
                return i
        return len(self.units) - 1

    # -- DRIVING MONITOR ------------------------------------------------------------------------
    def units_to_post(self, now: float) -> list[int]:
        """Return (and mark posted) the units to post now: next in line, previous resolved, in look-ahead."""
        out = []
        for i, u in enumerate(self.units):
            if u.phase != "new":
                continue
            if i > 0 and self.units[i - 1].phase != "resolved":
                break
            if u.span.s_start - self.s_vehicle > self.lookahead_m:
                break
            u.phase = "posted"
            u.posted_at = now
            out.append(i)
            if self.use_perception:
                break  # one unit at a time in flight to PERCEPTION (Figure 6)
        return out

    def resolve(self, idx: int, region: BaseGeometry | None, perceived: bool, how: str, sensed_at: float | None = None) -> None:
        """Mark unit `idx` resolved with PERCEPTION's region (world) or, if None, the map's; `sensed_at` [s sim]: its capture."""
        u = self.units[idx]
        u.phase = "resolved"
        u.perceived = perceived and region is not None and not region.is_empty
        u.region = region if u.perceived else u.span.region
        u.how = how
        u.sensed_at = sensed_at if u.perceived else None

    def sensed_at(self, indices: list[int]) -> float | None:
        """Return the newest capture stamp [s sim] among the perceived units `indices` (None: none perceived)."""
        stamps = [self.units[i].sensed_at for i in indices if self.units[i].sensed_at is not None]
        return max(stamps) if stamps else None

    def overdue(self, now: float) -> list[int]:
        """Return posted units PERCEPTION has not answered within the timeout [s] of sim time."""
        return [
            i for i, u in enumerate(self.units)
            if u.phase == "posted" and u.posted_at is not None and now - u.posted_at >= self.perception_timeout_s
        ]

    # -- LOCAL PATH PLANNER inputs -------------------------------------------------------------
    def newest_resolved(self) -> int:
        """Return the index of the newest unit resolved in an unbroken run from the first, or -1."""
        k = -1
        for i, u in enumerate(self.units):
            if u.phase != "resolved":
                break
            k = i
        return k

    def needs_plan(self) -> bool:
        """Return whether a newer unit has been resolved than the last plan covered."""
        return self.newest_resolved() > self.planned_through

    def plan_inputs(self) -> tuple[list[BaseGeometry], list[float], list[bool], list[int]]:
        """Return regions, far-edge s [m], perceived flags and indices of the units from here to the newest."""
        k = self.newest_resolved()
        lo = min(self.current_index(), max(k, 0))
        idx = list(range(max(0, lo - 1), k + 1))  # keep the unit behind: the vehicle may straddle its edge
        us = [self.units[i] for i in idx]
        return [u.region for u in us], [u.span.s_end for u in us], [u.perceived for u in us], idx

    def mark_planned(self, through: int, goal_s: float | None = None) -> None:
        """Record that a plan reaching the far edge of unit `through` (its goal at arc length `goal_s` [m]) was posted."""
        self.planned_through = max(self.planned_through, through)
        if through == len(self.units) - 1 and goal_s is not None:
            self.final_goal_s = goal_s

    def goal_meets_exit(self, goal_xy: np.ndarray, goal_s: float) -> bool:
        """Return whether a final goal (world [m], arc length [m]) lies where the exit condition holds."""
        ex = np.asarray(self.geom.exit_point)
        near = float(np.hypot(*(np.asarray(goal_xy)[:2] - ex))) <= self.geom.exit_radius
        return near or goal_s >= self.geom.path.length - self.geom.exit_radius

    # -- exit condition ------------------------------------------------------------------------
    def exited(self, xy: np.ndarray) -> bool:
        """Return whether the vehicle (world position) met the segment's exit condition."""
        ex = np.asarray(self.geom.exit_point)
        near = float(np.hypot(*(np.asarray(xy) - ex))) <= self.geom.exit_radius
        past = self.s_vehicle >= self.geom.path.length - self.geom.exit_radius
        return near or past

    def at_final_goal(self, tolerance: float = 0.5) -> bool:
        """Return whether the vehicle reached the goal of a plan through the last unit (within `tolerance` [m] along the path).

        The navigable region may end short of the exit (the margin, an obstacle near the segment's
        end): the last goal is then as far as the segment can be driven.
        """
        return self.final_goal_s is not None and self.s_vehicle >= self.final_goal_s - tolerance

    @property
    def perceived_count(self) -> int:
        """Return how many units PERCEPTION has seen."""
        return sum(1 for u in self.units if u.perceived)
