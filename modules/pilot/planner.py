"""LOCAL PATH PLANNER core: a kinematically feasible path inside the navigable region, with OMPL.

Frames: everything here is in one planar frame chosen by the caller (the PILOT plans in `world`
and converts the result to `local` for the HELM). Vehicles: `dubins` (forward only, minimum
turning radius: the Navlab, 7 m), `reeds_shepp` (forward and reverse, minimum turning radius),
`se2` (turns in place: the Terregator; the path is a polyline, headings follow the segments).

The validity checker accepts a state when its position lies inside the given region (the
DRIVING UNIT NAVIGATOR has already shrunk it by the safety margin). Sampling is reproducible: the
OMPL RNG is seeded once per process (`seed_ompl`) and planners stop on an iteration count, not on
wall-clock time (a wall-clock cap exists only as a safety net, and is off in lock-step, where the
simulator waits for the planner: there a search ends on its count alone, so the same inputs give
the same path however loaded the machine is).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Literal

import numpy as np
import shapely
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou
from pydantic import BaseModel, ConfigDict, Field
import shapely.ops
from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from wire.timemode import lockstep_enabled
from wire.se2 import wrap_angle
from modules.pilot.errors import PilotError

__all__ = ["PlannerConfig", "PlannedPath", "PlanningError", "LocalPathPlanner", "seed_ompl", "path_curvature"]

_SEEDED: list[int] = []


def seed_ompl(seed: int) -> bool:
    """Seed OMPL's global RNG once per process; return False if it was already seeded (kept as is)."""
    if _SEEDED:
        return _SEEDED[0] == seed
    ou.setLogLevel(ou.LOG_ERROR)
    ou.RNG.setSeed(int(seed) & 0x7FFFFFFF or 1)
    _SEEDED.append(seed)
    return True


class PlanningError(PilotError, RuntimeError):
    """No valid path: start or goal outside the region, or the search budget ran out."""


class PlannerConfig(BaseModel):
    """Local path planner settings: vehicle model, turning radius [m], output step [m], search budget."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["dubins", "reeds_shepp", "se2"] = "dubins"
    turning_radius: float = Field(7.0, gt=0.0, description="minimum turning radius [m] (dubins, reeds_shepp)")
    step: float = Field(0.25, gt=0.0, description="spacing of output poses along the path [m]")
    goal_tolerance: float = Field(0.3, gt=0.0, description="goal reached within this state distance [m]")
    max_iterations: int = Field(20000, gt=0, description="planner iterations per leg before giving up")
    max_wall_s: float = Field(5.0, gt=0.0, description="wall-clock safety cap per leg [s] (off in lock-step)")
    check_resolution: float = Field(0.05, gt=0.0, description="motion check resolution [m]")
    start_slack: float = Field(1.0, ge=0.0, description="the start's neighbourhood of this radius is valid [m]")
    bounds_pad: float = Field(10.0, ge=0.0, description="padding of the sampling box around region and poses [m]")
    fallback_kind: Literal["reeds_shepp"] | None = Field(
        None, description="when a forward-only search fails, search again allowing reverse (e.g. boxed in by an obstacle)"
    )
    footprint_x: tuple[float, ...] = Field(
        (0.0,), min_length=1, description="points along the vehicle's x axis [m] that must all lie in the region"
    )
    relax_fractions: tuple[float, ...] = Field(
        (), description="before reversing: the goal moved sideways by these fractions of the start's offset from its line [-]"
    )
    relax_max_m: float = Field(1.5, ge=0.0, description="the farthest a goal is moved sideways when relaxed [m]")


@dataclass(frozen=True)
class PlannedPath:
    """Poses (N,3) float64 (x [m], y [m], yaw [rad]), arc length s (N,) [m], direction (N,) ±1, curvature (N,) [1/m]."""

    poses: np.ndarray
    s: np.ndarray
    direction: np.ndarray
    curvature: np.ndarray

    @property
    def length(self) -> float:
        """Return the path length [m]."""
        return float(self.s[-1]) if len(self.s) else 0.0


def path_curvature(poses: np.ndarray) -> np.ndarray:
    """Return the curvature (N,) [1/m] of a pose sequence (N,3) from heading change per arc length."""
    poses = np.asarray(poses, dtype=np.float64)
    n = len(poses)
    k = np.zeros(n)
    if n < 2:
        return k
    ds = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    dyaw = np.array([wrap_angle(b - a) for a, b in zip(poses[:-1, 2], poses[1:, 2])])
    seg = np.where(ds > 1e-9, dyaw / np.maximum(ds, 1e-9), 0.0)
    k[:-1] = seg
    k[-1] = seg[-1]
    return k


class LocalPathPlanner:
    """Plan from a start pose through waypoint poses inside a region; reproducible from the OMPL seed."""

    def __init__(self, cfg: PlannerConfig = PlannerConfig(), seed: int = 0) -> None:
        """Configure the vehicle model and seed OMPL (once per process)."""
        self.cfg = cfg
        seed_ompl(seed)

    # -- state space ---------------------------------------------------------------------------
    def plan(self, start, waypoints, region: BaseGeometry, *, relax_goal: bool = False, reverse: bool = True) -> PlannedPath:
        """Plan from `start` (3,) through `waypoints` [(3,)…] (the last is the goal) inside `region`.

        When the search fails and `relax_goal` allows it, a forward path to the goal moved sideways
        towards the start's line (`relax_fractions`) is tried: a vehicle that need not stop exactly
        there merges over the next plan rather than shuffling. With `reverse` and a `fallback_kind`,
        a search that still fails is retried allowing reverse (`plan_reversing`).
        """
        try:
            return self._plan(start, waypoints, region)
        except PlanningError as exc:
            if "outside" in str(exc):
                raise
            if relax_goal and self.cfg.relax_fractions:
                relaxed = self._plan_relaxed(start, waypoints[-1], region)
                if relaxed is not None:
                    return relaxed
            if not reverse or self.cfg.fallback_kind is None:
                raise
            return self.plan_reversing(start, waypoints, region)

    def plan_reversing(self, start, waypoints, region: BaseGeometry) -> PlannedPath:
        """Plan as `plan` does, allowing reverse (the `fallback_kind` model, e.g. boxed in by an obstacle)."""
        if self.cfg.fallback_kind is None:
            raise PlanningError(f"a {self.cfg.kind} vehicle has no reversing model to fall back on")
        alt = LocalPathPlanner.__new__(LocalPathPlanner)
        alt.cfg = self.cfg.model_copy(update={"kind": self.cfg.fallback_kind, "fallback_kind": None})
        return alt._plan(start, waypoints, region)

    def _relaxed_goals(self, start, goal) -> list[np.ndarray]:
        """Return `goal` (3,) moved sideways towards `start`'s line by each of `relax_fractions` (capped at `relax_max_m`)."""
        start = np.asarray(start, dtype=np.float64).reshape(3)
        goal = np.asarray(goal, dtype=np.float64).reshape(3)
        n = np.array([-math.sin(goal[2]), math.cos(goal[2])])
        lateral = float(np.dot(start[:2] - goal[:2], n))
        out = []
        for f in self.cfg.relax_fractions:
            shift = float(np.clip(f * lateral, -self.cfg.relax_max_m, self.cfg.relax_max_m))
            if abs(shift) > 1e-3:
                out.append(np.array([goal[0] + shift * n[0], goal[1] + shift * n[1], goal[2]]))
        return out

    def _plan_relaxed(self, start, goal, region: BaseGeometry) -> PlannedPath | None:
        """Return one analytic curve to the first relaxed goal it reaches inside the region, or None."""
        for g in self._relaxed_goals(start, goal):
            try:
                space, si, s0, (target,) = self._problem(start, [g], region)
            except PlanningError:
                continue
            if si.checkMotion(s0, target):
                return self._sample(space, og.PathGeometric(si, s0, target))
        return None

    def _space(self) -> ob.StateSpace:
        if self.cfg.kind == "dubins":
            return ob.DubinsStateSpace(self.cfg.turning_radius, False)
        if self.cfg.kind == "reeds_shepp":
            return ob.ReedsSheppStateSpace(self.cfg.turning_radius)
        return ob.SE2StateSpace()

    @staticmethod
    def _set(state, pose) -> None:
        state.setX(float(pose[0]))
        state.setY(float(pose[1]))
        # OMPL's SO(2) bounds are [-pi, pi): a heading of exactly +pi (due west) is out of bounds and
        # the state can never be reached, so every yaw is wrapped into that interval first.
        state.setYaw(wrap_angle(float(pose[2])))

    def _problem(self, start, waypoints, region: BaseGeometry):
        """Return the state space, space information (validity: footprint in the region), start and goal states."""
        start = np.asarray(start, dtype=np.float64).reshape(3)
        wps = [np.asarray(w, dtype=np.float64).reshape(3) for w in waypoints]
        if not wps:
            raise PlanningError("no goal given")
        if region.is_empty:
            raise PlanningError("navigable region is empty")
        valid_geom = region
        fx = np.asarray(self.cfg.footprint_x, dtype=np.float64)
        if self.cfg.start_slack:
            c, s_ = math.cos(start[2]), math.sin(start[2])
            discs = [Point(start[0] + d * c, start[1] + d * s_).buffer(self.cfg.start_slack) for d in fx]
            valid_geom = shapely.union_all([valid_geom, *discs])
        if not shapely.contains_xy(region, start[0], start[1]):
            # The vehicle has strayed outside the region: let it back in by the shortest way.
            _, near = shapely.ops.nearest_points(Point(start[:2]), region)
            valid_geom = shapely.union(valid_geom, LineString([start[:2], (near.x, near.y)]).buffer(self.cfg.start_slack * 0.5 + 0.05))
        shapely.prepare(valid_geom)
        for i, w in enumerate(wps):
            if not shapely.contains_xy(valid_geom, w[0] + fx * math.cos(w[2]), w[1] + fx * math.sin(w[2])).all():
                raise PlanningError(f"waypoint {i} at ({w[0]:.2f}, {w[1]:.2f}) lies outside the navigable region")

        space = self._space()
        pts = np.vstack([start[:2], *[w[:2] for w in wps]])
        minx, miny, maxx, maxy = region.bounds
        pad = self.cfg.bounds_pad
        b = ob.RealVectorBounds(2)
        b.setLow(0, min(minx, pts[:, 0].min()) - pad)
        b.setHigh(0, max(maxx, pts[:, 0].max()) + pad)
        b.setLow(1, min(miny, pts[:, 1].min()) - pad)
        b.setHigh(1, max(maxy, pts[:, 1].max()) + pad)
        space.setBounds(b)
        si = ob.SpaceInformation(space)

        if len(fx) == 1 and fx[0] == 0.0:

            def valid(state) -> bool:
                return bool(shapely.contains_xy(valid_geom, state.getX(), state.getY()))

        else:

            def valid(state) -> bool:
                yaw = state.getYaw()
                xs = state.getX() + fx * math.cos(yaw)
                ys = state.getY() + fx * math.sin(yaw)
                return bool(shapely.contains_xy(valid_geom, xs, ys).all())

        si.setStateValidityChecker(valid)
        extent = max(1.0, space.getMaximumExtent())
        si.setStateValidityCheckingResolution(min(0.5, self.cfg.check_resolution / extent))
        si.setup()

        s0 = space.allocState()
        self._set(s0, start)
        goals = []
        for w in wps:
            g = space.allocState()
            self._set(g, w)
            goals.append(g)
        return space, si, s0, goals

    def _plan(self, start, waypoints, region: BaseGeometry) -> PlannedPath:
        space, si, s0, goals = self._problem(start, waypoints, region)
        # 1) one analytic curve from the start to the goal; 2) analytic curves through every
        # waypoint; 3) a sampling search (RRT) from the start to the goal, then shortcut it.
        path = og.PathGeometric(si, s0, goals[-1])
        if not si.checkMotion(s0, goals[-1]):
            chain = [s0, *goals]
            if len(goals) > 1 and all(si.checkMotion(a, b) for a, b in zip(chain[:-1], chain[1:])):
                path = og.PathGeometric(si, s0)
                for g in goals:
                    path.append(g)
            else:
                path = self._search(si, s0, goals[-1])
                ps = og.PathSimplifier(si)
                ps.reduceVertices(path)
                ps.collapseCloseVertices(path)
                if not path.check():
                    raise PlanningError("simplified path left the navigable region")
        return self._sample(space, path)

    def _search(self, si, a, b) -> og.PathGeometric:
        pdef = ob.ProblemDefinition(si)
        pdef.setStartAndGoalStates(a, b, self.cfg.goal_tolerance)
        planner = og.RRTConnect(si) if self.cfg.kind == "se2" else og.RRT(si)
        if self.cfg.kind != "se2":
            planner.setGoalBias(0.2)
        planner.setRange(max(2.0, self.cfg.turning_radius))
        planner.setProblemDefinition(pdef)
        planner.setup()
        count = [0]
        t_end = math.inf if lockstep_enabled() else time.monotonic() + self.cfg.max_wall_s

        def stop() -> bool:
            count[0] += 1
            return count[0] > self.cfg.max_iterations or time.monotonic() > t_end

        planner.solve(ob.PlannerTerminationCondition(stop))
        if not pdef.hasExactSolution():
            raise PlanningError(
                f"no path to the goal within {self.cfg.max_iterations} iterations (region too tight for the vehicle?)"
            )
        sol = pdef.getSolutionPath()
        return og.PathGeometric(sol)

    def _sample(self, space, path: og.PathGeometric) -> PlannedPath:
        if self.cfg.kind == "se2":
            return self._sample_polyline(path)
        rows = []
        tmp = space.allocState()
        for i in range(path.getStateCount() - 1):
            a, b = path.getState(i), path.getState(i + 1)
            m = max(1, int(math.ceil(space.distance(a, b) / self.cfg.step)))
            for k in range(0 if i == 0 else 1, m + 1):
                space.interpolate(a, b, k / m, tmp)
                rows.append([tmp.getX(), tmp.getY(), tmp.getYaw()])
        if len(rows) < 2:
            st = path.getState(0)
            rows = [[st.getX(), st.getY(), st.getYaw()]] * 2
        poses = np.array(rows, dtype=np.float64)
        poses[:, 2] = [wrap_angle(a) for a in poses[:, 2]]
        d = np.diff(poses[:, :2], axis=0)
        ds = np.hypot(*d.T)
        direction = np.ones(len(poses))
        fwd = d[:, 0] * np.cos(poses[:-1, 2]) + d[:, 1] * np.sin(poses[:-1, 2])
        direction[:-1] = np.where(fwd < -1e-9, -1.0, 1.0)
        direction[-1] = direction[-2] if len(direction) > 1 else 1.0
        s = np.concatenate([[0.0], np.cumsum(ds)])
        k = path_curvature(poses) * direction
        # A sample pair straddling a cusp (reeds_shepp) has a chord shorter than its arc: reuse a neighbour.
        for i in np.flatnonzero(direction[1:] != direction[:-1]):
            k[i] = k[i - 1] if i > 0 else 0.0
            if i + 1 < len(k) - 1:
                k[i + 1] = k[i + 2]
        return PlannedPath(poses=poses, s=s, direction=direction, curvature=k)

    def _sample_polyline(self, path: og.PathGeometric) -> PlannedPath:
        xy = np.array([[st.getX(), st.getY()] for st in (path.getState(i) for i in range(path.getStateCount()))])
        keep = [0] + [i for i in range(1, len(xy)) if np.hypot(*(xy[i] - xy[i - 1])) > 1e-6]
        xy = xy[keep]
        out = [np.array([xy[0, 0], xy[0, 1], path.getState(0).getYaw()])]
        if len(xy) == 1:
            p = out[0]
            return PlannedPath(np.array([p, p]), np.zeros(2), np.ones(2), np.zeros(2))
        for a, b in zip(xy[:-1], xy[1:]):
            yaw = math.atan2(b[1] - a[1], b[0] - a[0])
            seg = float(np.hypot(*(b - a)))
            n = max(1, int(math.ceil(seg / self.cfg.step)))
            for k in range(1 if np.allclose(out[-1][:2], a) and out[-1][2] == yaw else 0, n + 1):
                p = a + (b - a) * k / n
                out.append(np.array([p[0], p[1], yaw]))
        poses = np.array(out)
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
        k = np.zeros(len(poses))  # turns happen in place at the vertices: zero curvature while moving
        return PlannedPath(poses=poses, s=s, direction=np.ones(len(poses)), curvature=k)
