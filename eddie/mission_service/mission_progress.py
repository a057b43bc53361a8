"""The EDDIE mission service's core: each step's route and goal, and the step outcomes judged from the believed pose.

EDDIE has no CAPTAIN on a blackboard: the mission is compiled into annotations, and the vehicle
drives the route the triggers shape. The mission service only keeps the mission's status (the
CAPTAIN's sequencer, `modules.captain.sequencer.MissionRun`, so `sidewalk submit` reads the same
states) and judges each step by where the robot believes it is (navigator `world` ← `local` ∘
controller `local` pose): reached within `reach_m` less a margin of the step's goal (or, for a step kept
to a side, of the goal moved into the lane of the road the route arrives on, on the kept side of the
route's last direction: the mission read on the robot's map, `eddie.missions.lane`), at the closest
approach (the route's end, or the belief passing the goal or stopping closing on it), or (as the PILOT
judges arrival under CODGER: along its path, within `progress_m` of the end) projected within
`progress_m` of the step route's end while within 2·`reach_m` of the goal (within `reach_m` of it or
its lane's goal for a step kept to a side), or on the next step's route, within `reach_m` of it and
`progress_m` along it, while within 2·`reach_m` of the goal or past the route's end (the goal went by
between two looks, or the vehicle turned onto the next route at a corner) → succeeded, at once for a step driven
through and, for one the vehicle stops at (the last; a `stop` or `wait` trigger's with obstacle stop holding it
there), once the vehicle is at rest (`modules.captain.arrival`, from the controller's odometry); no progress for `stall_s` [s] sim → failed (progress: the route left to drive, the believed position projected
onto the step's route, shrinking by `progress_m`). Routes come from the MAP NAVIGATOR's route selection on the robot's map,
one step after the other from the previous goal, as the mission compiler lays them out.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Point
from pydantic import BaseModel, ConfigDict, Field

from eddie.missions.destination import destination_object, destination_point
from eddie.missions.lane import goal_kept_offset, goal_lane_offset, kept_lane_offset, lane_point, shift_into_lane
from eddie.modules.errors import EddieModuleError
from modules.captain.arrival import REST_TIMEOUT_S, RestDetector
from modules.captain.progress import RouteProgress
from modules.captain.sequencer import MissionRun, Next
from modules.map_navigator import MapData, RouteError, RouteOptions, select_route
from modules.vocabulary import Mission, MissionStatus, MissionStep, MissionStepSpec, StepProgress, StepResult, Waiting

__all__ = ["StepGoal", "MissionRouteError", "step_goals", "mission_route", "MissionProgress"]

#: inside the reach, a belief this much closer to the goal [m] counts as still closing on it
CLOSING_M = 0.05
#: inside the reach, a belief this much farther than its closest [m] has passed the goal: the step ends
PASSED_M = 0.25
#: inside the reach, no closer for this long [s] sim (the vehicle has stopped): the step ends
SETTLE_S = 3.0


class MissionRouteError(EddieModuleError, ValueError):
    """A mission step has no route on the robot's map (the message names the step)."""


class StepGoal(BaseModel):
    """One step's route (N, 2) [m] in `world` and its goal (x, y) [m] in `world`."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    step_index: int = Field(ge=0)
    route: tuple[tuple[float, float], ...] = Field(min_length=2)
    goal: tuple[float, float]
    speed_mps: float | None = None
    #: how close [m] to the goal counts as reached (the step's tolerance)
    reach_m: float = Field(1.0, gt=0.0)
    #: the offset [m] left (+) of the route's last direction of the lane the step keeps to (a quarter of the width of
    #: the road the route arrives on; None: no side): a road follower drives in the lane (issue 13), and ends in it
    lane_offset_m: float | None = None

    @property
    def lane_goal(self) -> tuple[float, float] | None:
        """Return the goal moved into the kept lane of the route's last direction (None: the step keeps to no side)."""
        if self.lane_offset_m is None:
            return None
        (ax, ay), (bx, by) = self.route[-2], self.route[-1]
        return lane_point(self.goal, self.lane_offset_m, math.atan2(by - ay, bx - ax))


def step_goals(map_data: MapData, start_xy: tuple[float, float], mission: Mission, *, vehicle: str = "terregator") -> list[StepGoal]:
    """Return every step's route and goal, each from the previous goal (the first from `start_xy`, `world` [m])."""
    out: list[StepGoal] = []
    at = start_xy
    for i, step in enumerate(mission.steps):
        try:
            route = select_route(map_data, at, step.destination, step.constraints, RouteOptions(vehicle=vehicle))
        except RouteError as exc:
            raise MissionRouteError(f"step {i + 1} ({step.name}): {exc}") from None
        line = route.polyline()
        if len(line) < 2:
            line = (at, route.goal_xy)
        _obj, obj_xy = destination_object(map_data, step.destination.place, route.goal_xy)
        goal = destination_point(route.goal_xy, obj_xy, line)  # beside its object, if any
        out.append(StepGoal(step_index=i, route=tuple(line), goal=goal, speed_mps=step.constraints.speed_limit,
                            reach_m=step.tolerance, lane_offset_m=goal_lane_offset(route, step.constraints.keep)))
        at = route.goal_xy
    return out


def mission_route(map_data: MapData, goals: list[StepGoal], steps: list[MissionStepSpec], *, speed_mps: float, keep_offset_m: float,
                  edge_keep_m: float, in_lane: bool = False) -> tuple[list[tuple[float, float]], list[float], list[float]]:
    """Return the mission's whole route (x, y) [m] in `world`, the speed [m/s] from each point on, and the offset [m] left (+)
    of the route at each point of the lane it is driven in.

    The route is the roads' centre line, each step's after the other. A step kept to a side is driven in its lane
    (`kept_lane_offset` of the nearest road's width at each vertex, at most `keep_offset_m` [m], leaving `edge_keep_m` [m]
    inside the road's edge), as the PILOT plans it, and ends in its goal's lane (`goal_kept_offset`: a wide plaza's,
    not a walk's); 0 elsewhere. A step's speed is its limit, at most `speed_mps`.
    `in_lane`: the points moved by their offsets (`shift_into_lane`).
    """
    pts: list[tuple[float, float]] = []
    speeds: list[float] = []
    offsets: list[float] = []
    edges = [(LineString(e.coords), e.width) for e in map_data.world.edges]
    for g, step in zip(goals, steps):
        v = min(g.speed_mps or speed_mps, speed_mps)
        route = np.asarray(g.route, dtype=np.float64)
        off = np.zeros(len(route))
        keep = step.constraints.keep
        if edges and keep in ("right", "left"):
            widths = [min(edges, key=lambda le: le[0].distance(Point(p)))[1] for p in route]
            off = np.array([kept_lane_offset(keep, w, keep_offset_m, edge_keep_m) for w in widths])
            end = goal_kept_offset(g.lane_offset_m, edge_keep_m)
            if abs(end) > abs(off[-1]):
                off[-1] = end
        for p, o in zip(route, off):
            if pts and math.dist(pts[-1], p) < 0.05:
                continue  # a step starts at the last one's goal: the goal keeps its lane
            pts.append((float(p[0]), float(p[1])))
            speeds.append(v)
            offsets.append(float(o))
    if in_lane and pts:
        pts = [(float(x), float(y)) for x, y in shift_into_lane(np.asarray(pts), np.asarray(offsets))]
    return pts, speeds, offsets


class MissionProgress:
    """Sequence one mission's steps by the believed pose; pure (the caller publishes `status` when it changes)."""

    def __init__(self, mission: Mission, goals: list[StepGoal], *, submitted_at: float | None = None,
                 margin_m: float = 0.3, stall_s: float = 60.0, progress_m: float = 0.5, stops_at_steps: bool = True) -> None:
        """Judge steps by `goals`: reached `margin_m` [m] inside a goal's reach (the robot's belief is not truth); failed after `stall_s` [s] sim without `progress_m` [m] of progress.

        A step the vehicle stops at is claimed once it is at rest (`modules.captain.arrival`): the last step, and with
        `stops_at_steps` (obstacle stop holds the vehicle at a `stop` or `wait` trigger's object) every such step.
        """
        if len(goals) != len(mission.steps):
            raise ValueError(f"{len(goals)} goals for {len(mission.steps)} steps")
        self.run = MissionRun(mission, submitted_at=submitted_at)
        self.goals = goals
        self.margin_m, self.stall_s, self.progress_m = margin_m, stall_s, progress_m
        self.stops_at_steps = stops_at_steps
        self.rest = RestDetector()
        self._arrived: tuple[str, float] | None = None  # a stopping step's arrival (reason, when [s sim]) awaiting rest
        self._track: RouteProgress | None = None  # the current step's progress along its route
        self._closest, self._closest_at = math.inf, 0.0  # the nearest the belief came to the goal inside the reach [m], when [s]
        self._wait_until: float | None = None
        self._lines: dict[int, LineString] = {}

    @property
    def status(self) -> MissionStatus:
        """Return the mission status (the CAPTAIN's form)."""
        return self.run.status

    def start(self, now: float) -> MissionStep:
        """Start at sim time `now` [s]; return the first step."""
        step = self.run.start(now)
        self._begin(step.step_index, now)
        return step

    def _begin(self, i: int, now: float) -> None:
        self._track = RouteProgress(i, self.goals[i].route, now, progress_m=self.progress_m)
        self._closest, self._closest_at = math.inf, now
        self._arrived = None

    @property
    def arrival(self) -> tuple[str, float] | None:
        """Return the current step's arrival awaiting rest (why, when [s sim]), else None."""
        return self._arrived

    def _stops(self, i: int) -> bool:
        """Return whether the vehicle comes to rest at step `i`'s goal (so that its arrival is claimed at rest)."""
        return i == len(self.goals) - 1 or (self.stops_at_steps and self.run.mission.steps[i].trigger.action != "continue")

    def _arrive(self, i: int, reason: str, now: float) -> bool:
        """Step `i` reached its goal at sim time `now` [s]: end it, or, if the vehicle stops there, once it is at rest."""
        if not self._stops(i):
            return self._finish(i, reason, now)
        if self._arrived is None:
            self._arrived = (reason, now)
        return self._settle(i, now)

    def _settle(self, i: int, now: float) -> bool:
        assert self._arrived is not None
        reason, at = self._arrived
        if self.rest.at_rest(now):
            return self._finish(i, f"{reason}; at rest", now)
        if now - at >= REST_TIMEOUT_S:
            return self._finish(i, f"{reason}; not at rest {REST_TIMEOUT_S:.0f} s after (claimed anyway)", now)
        return False

    def _finish(self, i: int, reason: str, now: float) -> bool:
        return self._apply(self.run.step_finished(StepResult(
            mission_id=self.run.mission.mission_id, step_index=i, success=True, reason=reason), now), now)

    def _apply(self, nxt: Next, now: float) -> bool:
        if nxt.kind == "wait":
            self._wait_until = nxt.until
        elif nxt.kind == "step":
            assert nxt.step is not None
            self._begin(nxt.step.step_index, now)
        return True

    def progress(self, now: float, pose: tuple[float, float, float] | None, waiting: Waiting = "") -> StepProgress | None:
        """Return where the running step is at sim time `now` [s] with the believed `pose` (`world`; None: unknown), else None."""
        if self.run.finished or self.run.current_step is None or self._track is None:
            return None
        return self._track.report(now, pose, waiting)

    def update(self, now: float, world_xy: tuple[float, float] | None, yaw: float | None = None,
               odometry: tuple[float, float, float, float] | None = None, waiting: str = "") -> bool:
        """Take the believed position (`world` [m], None: not known) and heading (`yaw` [rad], None: not known) at sim
        time `now` [s]; return whether the status changed. `waiting` says why the vehicle waits, if it does (a stalled
        step's failure names it).

        `odometry` (stamp [s sim], x, y [m], yaw [rad] in `local`) tells whether the vehicle is at rest; without it the
        believed position does (a position fix moving it counts as motion).
        """
        if odometry is not None:
            self.rest.feed(*odometry)
        elif world_xy is not None:
            self.rest.feed(now, world_xy[0], world_xy[1], yaw or 0.0)
        if self.run.finished or self.run.current_step is None:
            return False
        i = self.run.current_step
        mid = self.run.mission.mission_id
        if self._wait_until is not None:
            if now < self._wait_until:
                return False
            self._wait_until = None
            return self._apply(self.run.wait_over(now), now)
        if self._arrived is not None:  # arrived at a stop: claimed once at rest
            return self._settle(i, now)
        if world_xy is not None:
            sg = self.goals[i]
            lane_goal = sg.lane_goal
            d = min(math.hypot(world_xy[0] - g[0], world_xy[1] - g[1]) for g in (sg.goal, lane_goal) if g is not None)
            # progress is measured along the route: a route may lead away from its goal for a while
            assert self._track is not None
            left = self._track.left(world_xy)
            inside = d <= max(self.goals[i].reach_m - self.margin_m, 0.2)
            if inside and d < self._closest - CLOSING_M:
                self._closest, self._closest_at = d, now
            # once inside the reach, drive on while the belief still closes on the goal: the step ends at the
            # route's end or the closest approach (passing it, leaving the reach, or no closer for a while),
            # not at the reach's edge (the belief is not truth)
            if not math.isinf(self._closest) and (not inside or left <= self.progress_m or d > self._closest + PASSED_M
                                                  or now - self._closest_at >= SETTLE_S):
                return self._arrive(i, f"reached within {min(d, self._closest):.2f} m of the goal", now)
            # a step kept to a side ends on that side: the other lane projects onto the route's end too, so
            # there the belief must be within the reach of the goal or its lane's goal
            near_end = d <= (sg.reach_m if lane_goal is not None else 2.0 * sg.reach_m)
            if left <= self.progress_m and near_end:
                # the belief may be off across the route by more than the reach (a wide plaza gives vision
                # no edges); driving to the route's end is arrival, as the PILOT's along-path test
                return self._arrive(i, f"reached the end of its route ({d:.2f} m from the goal, believed)", now)
            if (left <= self.progress_m or d <= 2.0 * sg.reach_m) and i + 1 < len(self.goals):
                # the next step's route starts at this goal, and the vehicle drives on into it: a belief past this
                # route's end, within the reach of the next route and along it, went through the goal between two
                # looks (at RTF 50 a look can come seconds of sim apart, and a pass-by takes a few); one near the
                # goal and near the next route's start turned onto it short of the corner
                nxt = self._line(i + 1)
                p = Point(world_xy)
                along = float(nxt.project(p))
                went_by = left <= self.progress_m or along <= 2.0 * sg.reach_m
                if self.progress_m <= along and went_by and nxt.distance(p) <= sg.reach_m:
                    return self._arrive(i, f"passed its goal onto the next step's route ({along:.1f} m along it, believed)", now)
            self._track.note(now, left)
        assert self._track is not None
        if self._track.since(now) > self.stall_s:
            best = self._track.best_left
            left = "" if math.isinf(best) else f"; {best:.1f} m of its route left"
            why = f"no progress along the route for {self.stall_s:.0f} s (the believed position, navigator ∘ controller{left})"
            if waiting:
                why += f", waiting: {waiting}"
            return self._apply(self.run.step_finished(StepResult(mission_id=mid, step_index=i, success=False, reason=why), now), now)
        return False

    def _line(self, i: int) -> LineString:
        line = self._lines.get(i)
        if line is None:
            line = self._lines[i] = LineString(self.goals[i].route)
        return line

    def cancel(self, now: float, reason: str = "cancelled by request") -> None:
        """Cancel the mission at sim time `now` [s]."""
        self.run.cancel(now, reason)
