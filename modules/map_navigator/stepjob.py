"""One mission step in the MAP NAVIGATOR: plan, hand out one segment at a time, replan on failure.

Pure: no I/O. The service posts what it returns and feeds segment results back.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from modules.map_navigator.describe import DescribeOptions, describe_segment
from modules.map_navigator.mapdata import MapData
from modules.map_navigator.off_road import off_road_plan
from modules.map_navigator.route import NoRouteError, Route, RouteError, RouteOptions, select_route
from modules.map_navigator.segments import SegmentOptions, SegmentPlan, segment_route
from modules.vocabulary import MissionStep, RoutePlan, RouteSegmentDescription, SegmentResult, StepResult

__all__ = ["NavigatorOptions", "StepJob", "Planned", "vehicle_turn_radius", "vehicle_describe_radius", "DESCRIBE_REACH_M",
           "TURN_SPEED_M_S"]

#: How far beyond its turning radius [m] a vehicle's local plans may reach objects: its half width,
#: the PILOT's obstacle clearance and the position uncertainty it adds to that clearance.
DESCRIBE_REACH_M = 5.0

#: A retry of a failed way (there was no other) that drove less than this [m] is not retried again.
RETRY_MIN_PROGRESS_M = 1.0

#: Speed [m/s] through turns for a vehicle with a turning radius: its steering turns at a limited
#: rate, and the slower it goes the less it overshoots coming out of the arc (the Navlab: 1.5 m/s).
TURN_SPEED_M_S = 1.5


def vehicle_turn_radius(vehicle: str) -> float:
    """Return the minimum turning radius [m] the decomposition allows for: Navlab 7 m, Terregator 0 m."""
    return 7.0 if vehicle == "navlab" else 0.0


def vehicle_describe_radius(vehicle: str, base_m: float) -> float:
    """Return how far from a segment's centreline [m] objects are copied for `vehicle`: at least `base_m`.

    A vehicle that cannot turn in place swings up to its turning radius off the centreline (the
    Dubins arcs of its local plans), so it must be told about objects that far out and then some:
    the Navlab (7 m) gets 12 m, the Terregator the base radius.
    """
    return max(base_m, vehicle_turn_radius(vehicle) + DESCRIBE_REACH_M)


@dataclass(frozen=True)
class NavigatorOptions:
    """MAP NAVIGATOR settings: vehicle, replans allowed per step, decomposition and description settings."""

    vehicle: str = "terregator"
    max_replans: int = 2
    segment: SegmentOptions = field(default_factory=SegmentOptions)
    describe: DescribeOptions = field(default_factory=DescribeOptions)

    def segment_options(self) -> SegmentOptions:
        """Return the decomposition settings with the vehicle's turning radius."""
        return replace(self.segment, turn_radius_m=max(self.segment.turn_radius_m, vehicle_turn_radius(self.vehicle)))

    def describe_options(self) -> DescribeOptions:
        """Return the description settings for the vehicle: its object radius; slow turns on their arcs if it has a turning radius."""
        turn_speed, on_arc = self.describe.turn_speed_limit, self.describe.turn_on_arc
        if vehicle_turn_radius(self.vehicle) > 0.0:  # its turns are arcs: slow down and follow them
            turn_speed = TURN_SPEED_M_S if turn_speed is None else turn_speed
            on_arc = True
        return replace(self.describe, describe_radius_m=vehicle_describe_radius(self.vehicle, self.describe.describe_radius_m),
                       turn_speed_limit=turn_speed, turn_on_arc=on_arc)


@dataclass(frozen=True)
class Planned:
    """A (re)plan: the route plan token and the segment descriptions, in driving order."""

    plan: RoutePlan
    segments: tuple[RouteSegmentDescription, ...]


class StepJob:
    """Route one mission step from `start_xy` [m] (world frame): plan, segments, results, replans."""

    def __init__(self, m: MapData, step: MissionStep, start_xy: tuple[float, float], options: NavigatorOptions = NavigatorOptions(),
                 *, first_revision: int = 0) -> None:
        self.map = m
        self.step = step
        self.options = options
        self.position = (float(start_xy[0]), float(start_xy[1]))
        self.revision = first_revision - 1
        self._first_revision = first_revision
        self.blocked: set[str] = set()
        self.planned: Planned | None = None
        self._plans: list[SegmentPlan] = []
        self.cursor = 0
        self.done_length = 0.0
        self.segments_done = 0
        self.result: StepResult | None = None
        self._retreat: tuple[float, float] | None = None
        self.retried = False  # the newest plan retries the way that failed (there was no other)
        self._may_retry = True

    @property
    def plan_id(self) -> str:
        """Return the id of the current plan: <mission>.<step>.<revision>."""
        return f"{self.step.mission_id}.{self.step.step_index}.{self.revision}"

    def _route(self) -> Route:
        opts = RouteOptions(vehicle=self.options.vehicle, blocked_edges=frozenset(self.blocked), retreat=self._retreat)  # type: ignore[arg-type]
        try:
            return select_route(self.map, self.position, self.step.destination, self.step.constraints, opts)
        except NoRouteError as exc:
            if not self.blocked or not self._may_retry:
                raise
            # No way around what failed: try the same way again from here (a vehicle that got stuck
            # or a plan that failed for a while) rather than give up while replans remain.
            again = RouteOptions(vehicle=self.options.vehicle)  # type: ignore[arg-type]
            try:
                route = select_route(self.map, self.position, self.step.destination, self.step.constraints, again)
            except RouteError:
                raise exc from None
            self.retried = True
            return route

    def plan(self) -> Planned | StepResult:
        """Plan (or replan) from the current position; return the plan, or the step's result if done/failed."""
        self.revision += 1
        self.retried = False
        if self.step.destination.off_road:  # no road: one cross-country segment the PILOT plans on the terrain
            plan, seg = off_road_plan(self.step, self.position, self.plan_id, self.revision)
            self._plans = []
            self.cursor = 0
            self.planned = Planned(plan, (seg,))
            return self.planned
        try:
            route = self._route()
        except RouteError as exc:
            return self._finish(False, str(exc) if self.revision == self._first_revision else f"replanning failed: {exc}")
        self._plans = segment_route(route, self.map, self.options.segment_options())
        self.cursor = 0
        n = len(self._plans)
        describe = self.options.describe_options()
        segs = tuple(
            describe_segment(sp, self.map, segment_id=f"{self.plan_id}.{i}", plan_id=self.plan_id, index=i,
                             constraints=self.step.constraints, last=(i == n - 1), opts=describe)
            for i, sp in enumerate(self._plans)
        )
        poly = route.polyline() if route.legs else (route.start_xy, route.goal_xy)
        plan = RoutePlan(
            plan_id=self.plan_id, mission_id=self.step.mission_id, step_index=self.step.step_index, revision=self.revision,
            node_ids=route.node_ids, edge_ids=route.edge_ids, segment_count=n, length_m=route.length, cost=route.cost,
            polyline=poly, start_xy=route.start_xy, goal_xy=route.goal_xy, goal_name=route.goal_name,
        )
        self.planned = Planned(plan, segs)
        if n == 0:
            self._finish(True, "already at the destination")
        return self.planned

    def current(self) -> RouteSegmentDescription | None:
        """Return the segment the PILOT should drive now, or None when the step is over."""
        if self.result is not None or self.planned is None or self.cursor >= len(self.planned.segments):
            return None
        return self.planned.segments[self.cursor]

    def segment_done(self, res: SegmentResult) -> RouteSegmentDescription | Planned | StepResult:
        """Apply the PILOT's result for the current segment; return the next segment, a new plan, or the step result."""
        seg = self.current()
        if seg is None or res.segment_id != seg.segment_id:
            raise ValueError(f"result for segment {res.segment_id} but the current segment is {seg.segment_id if seg else None}")
        if res.success:
            self.position = res.end_xy if res.end_xy is not None else seg.exit.point
            self.done_length += seg.length_m
            self.segments_done += 1
            self.cursor += 1
            nxt = self.current()
            if nxt is None:
                return self._finish(True, "")
            return nxt
        if res.end_xy is not None:
            self.position = res.end_xy
        if self._plans:
            self.blocked.update(self._plans[self.cursor].edge_ids)
        self._retreat = _travel_direction(seg.centreline, self.position)
        why = f"segment {seg.segment_index} ({seg.mode}) failed: {res.reason or 'no reason given'}"
        # A retry of the same way that got nowhere (< RETRY_MIN_PROGRESS_M) is not tried yet again.
        self._may_retry = not self.retried or res.distance_m >= RETRY_MIN_PROGRESS_M
        if self.revision - self._first_revision >= self.options.max_replans:
            return self._finish(False, f"{why}; no replans left ({self.options.max_replans} allowed)")
        out = self.plan()
        if isinstance(out, StepResult):
            self.result = out.model_copy(update={"reason": f"{why}; {out.reason}"})
            return self.result
        return out

    def cancel(self, reason: str = "cancelled") -> StepResult:
        """End the step as failed because it was cancelled."""
        return self._finish(False, reason)

    def _finish(self, success: bool, reason: str) -> StepResult:
        if self.result is None:
            self.result = StepResult(
                mission_id=self.step.mission_id, step_index=self.step.step_index, success=success, reason=reason,
                route_length_m=self.done_length, segments_done=self.segments_done, replans=max(0, self.revision - self._first_revision),
            )
        return self.result



def _travel_direction(coords: tuple[tuple[float, float], ...], xy: tuple[float, float]) -> tuple[float, float]:
    """Return the unit direction of travel along `coords` at the point nearest `xy` (world frame)."""
    import shapely

    line = shapely.LineString(coords)
    s = line.project(shapely.Point(xy))
    a = line.interpolate(max(0.0, s - 0.5))
    b = line.interpolate(min(line.length, s + 0.5))
    dx, dy = b.x - a.x, b.y - a.y
    n = (dx * dx + dy * dy) ** 0.5
    if n < 1e-9:
        (x0, y0), (x1, y1) = coords[0], coords[-1]
        dx, dy, n = x1 - x0, y1 - y0, max(1e-9, ((x1 - x0) ** 2 + (y1 - y0) ** 2) ** 0.5)
    return (dx / n, dy / n)
