"""The cross-country planner (Navlab 1990 §2.4): an admissible path in (x, y, θ) across rough terrain, and what it cost.

The three kinds of constraint: *sensing* and *environmental* ones (tip-over, high-centring,
collision; `constraints`) are evaluated on voxels of the configuration space, whole voxels at a
time, by the `resolution_hierarchy` over the terrain pyramid; *kinematic* ones shape the motions
the search may make — forward arcs no tighter than the minimum turning radius (the Navlab: 7 m),
for a skid-steered vehicle (the Terregator) turns in place as well, and, with `reverse_cost`, the same arcs
backed up (at a higher cost per metre). The search is a weighted
hybrid A*: states are continuous configurations, a lattice of `closed_cell` [m] × `lattice_headings`
keeps one state per cell, and every motion is sampled every `sample` [m] (or heading step); each
sample must lie in an admissible voxel — of whatever level decided it — or be admissible itself.
The voxels are grown by the sampling step and the control uncertainty (the paper's voxel
expansion), so the path is admissible between its samples too.

What a plan reports keeps the hierarchy visible: the terrain queries (voxels classified from the
pyramid — the paper's Figure 2.16 plan made 1,493), the voxels classified per level and class,
the level that certified each pose of the path, and, to compare, how many configurations a
pixel-sized tessellation of the map would have to evaluate.

Frames: start, goal and path in the pyramid's frame (usually `world`): x, y [m], θ [rad] CCW from +x.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass

import numpy as np
from numba import njit, types
from numba.typed import Dict
from pydantic import BaseModel, ConfigDict, Field

from modules.terrain.constraints import ADMISSIBLE, Constraint, constraints_in
from modules.terrain.cost_to_go import cost_to_go
from modules.terrain.errors import InadmissibleGoal, InadmissibleStart, NoAdmissiblePath, TerrainError
from modules.terrain.pyramid import TerrainPyramid
from modules.terrain.resolution_hierarchy import NOT_CACHED, LevelCounts, ResolutionHierarchy, cached_level, classify_pose
from modules.terrain.vehicle_model import TerrainVehicle
from wire.se2 import wrap_angle

__all__ = ["CrossCountrySettings", "CrossCountryPlan", "CrossCountryPlanner"]


class CrossCountrySettings(BaseModel):
    """The planner's resolution hierarchy, motions, uncertainty, goal and search budget."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    leaf_voxel: float = Field(0.4, gt=0.0, description="side of the finest voxels [m] (rounded to a pyramid level)")
    voxel_levels: int = Field(6, ge=1, description="voxel levels, each twice the side and half the heading intervals of the one below")
    headings: int = Field(32, ge=1, description="heading intervals of the finest voxels (a power of two)")
    step: float = Field(1.5, gt=0.0, description="arc length of one motion [m]")
    sample: float = Field(0.2, gt=0.0, description="a motion is checked at most this far apart [m]")
    arcs: int = Field(5, ge=1, description="motions per state: curvatures evenly spread over ±1/turning radius (odd: one straight)")
    reverse_cost: float | None = Field(None, gt=0.0, description="backing up: the same arcs driven in reverse, each metre costing this many "
                                       "(None: forward only) — how a car-like vehicle gets out of a dead end")
    skid_turning_radius: float = Field(2.0, gt=0.0, description="tightest arc of a skid-steered vehicle besides its turns in place [m]")
    turn_in_place: float = Field(math.radians(22.5), gt=0.0, description="heading change of one turn in place [rad] (skid steer)")
    turn_cost: float = Field(0.5, ge=0.0, description="cost of heading change [m/rad], added to the distance driven")
    position_uncertainty: float = Field(0.1, ge=0.0, description="control error of the position the voxels are grown by [m]")
    heading_uncertainty: float = Field(math.radians(1.0), ge=0.0, description="control error of the heading [rad]")
    goal_tolerance: float = Field(1.0, gt=0.0, description="a path ends within this distance of the goal [m]")
    goal_heading_tolerance: float | None = Field(None, gt=0.0, description="…and within this of its heading [rad] (None: any)")
    closed_cell: float = Field(0.5, gt=0.0, description="side of the search lattice's cells [m]")
    lattice_headings: int = Field(64, ge=1, description="heading intervals of the search lattice (a motion at the tightest arc should cross one)")
    heuristic_weight: float = Field(1.5, ge=1.0, description="weight on the distance to go")
    heuristic_cell: float = Field(0.8, gt=0.0, description="node size of the coarse distance to go around obvious obstacles [m]")
    max_states: int = Field(50_000, ge=10, description="search budget: states generated before the search gives up")
    max_unknown_share: float = Field(0.0, ge=0.0, le=1.0, description="share of the body's area that may be unknown terrain")
    cover: float = Field(3.0, gt=0.0, description="pyramid nodes across a body part a voxel's bound reads (more: tighter, slower)")


@dataclass(frozen=True)
class CrossCountryPlan:
    """An admissible path and what planning it cost.

    `poses` (n, 3) float64 x, y [m], θ [rad] from the start to within the goal tolerance, at most
    `sample` apart; `curvature` (n,) float64 [1/m] of the motion reaching each pose (0 at the start;
    ±inf for a turn in place); `levels` (n,) int8 the voxel level that certified each pose (−1: the
    configuration itself). `terrain_queries` voxels (and single configurations) classified from the
    pyramid, `node_reads` pyramid nodes they read, `voxels` per level and class;
    `fine_configurations` what a pixel-sized tessellation of the map would evaluate (cells × headings).
    `direction` (n,) float64 +1 where the motion reaching the pose drives forward, −1 where it backs up.
    """

    poses: np.ndarray
    curvature: np.ndarray
    levels: np.ndarray
    length: float
    terrain_queries: int
    node_reads: int
    voxels: tuple[LevelCounts, ...]
    fine_configurations: int
    expansions: int
    states: int
    plan_ms: float
    direction: np.ndarray | None = None


class CrossCountryPlanner:
    """Plans on one terrain pyramid for one vehicle; `plan` starts each search with an empty voxel cache."""

    def __init__(self, pyramid: TerrainPyramid, vehicle: TerrainVehicle, settings: CrossCountrySettings | None = None) -> None:
        """Prepare the motions and the hierarchy of `vehicle` on `pyramid`."""
        self.pyramid = pyramid
        self.vehicle = vehicle
        self.settings = s = settings or CrossCountrySettings()
        if s.headings & (s.headings - 1):
            raise TerrainError(f"headings must be a power of two, not {s.headings}")
        self._motions = _motions(vehicle, s)
        dx, dy, dth, n, cost, kappa = self._motions
        spacing = float(np.max(np.hypot(np.diff(np.concatenate([np.zeros((dx.shape[0], 1)), dx], axis=1), axis=1),
                                        np.diff(np.concatenate([np.zeros((dy.shape[0], 1)), dy], axis=1), axis=1))))
        turn = float(np.max(np.abs(np.diff(np.concatenate([np.zeros((dth.shape[0], 1)), dth], axis=1), axis=1))))
        # Any pose between two samples lies within half their spacing of one of them.
        self.margin_xy = 0.5 * spacing + s.position_uncertainty
        self.margin_theta = 0.5 * turn + s.heading_uncertainty
        self.hierarchy = ResolutionHierarchy(pyramid, vehicle, s.leaf_voxel, s.voxel_levels, s.headings, self.margin_xy,
                                             self.margin_theta, s.max_unknown_share, s.cover)

    def plan(self, start: tuple[float, float, float], goal: tuple[float, float, float]) -> CrossCountryPlan:
        """Return an admissible path from `start` to `goal` (x [m], y [m], θ [rad]; the goal's θ counts only with a heading tolerance)."""
        t0 = time.perf_counter()
        s, p, hier = self.settings, self.pyramid, self.hierarchy
        hier.reset()
        sx, sy, sth = (float(v) for v in start)
        gx, gy, gth = (float(v) for v in goal)
        state, _, why = hier.classify(sx, sy, sth)
        if state != ADMISSIBLE:
            raise InadmissibleStart(f"the start ({sx:.2f}, {sy:.2f}, {math.degrees(sth):.0f}°) is not admissible: "
                                    f"{_names(why)}", why)
        self._check_goal(gx, gy, gth)
        dx, dy, dth, n, cost, kappa = self._motions
        cap = s.max_states
        xs, ys, ths, gs = (np.empty(cap) for _ in range(4))
        parent = np.empty(cap, np.int64)
        motion = np.empty(cap, np.int64)
        used = np.empty(cap, np.int64)
        blocked = np.zeros(16, np.int64)
        a = hier.arrays
        heading_tol = -1.0 if s.goal_heading_tolerance is None else s.goal_heading_tolerance
        togo = cost_to_go(p, self.vehicle, sx, sy, gx, gy, s.heuristic_cell)
        found, nstates, expansions = _search(
            sx - p.origin_x, sy - p.origin_y, sth, gx - p.origin_x, gy - p.origin_y, gth, s.goal_tolerance, heading_tol,
            dx, dy, dth, n, cost, s.closed_cell, s.lattice_headings, s.heuristic_weight, togo.distance, togo.size,
            p.features, p.offsets, p.dims, p.resolution, p.shape[0], p.shape[1], a.wheels, a.moments, a.boxes, a.body,
            a.scalars, hier.meta, hier.cache, hier.touched, hier.cache_offsets, hier.margins, hier.scratch, hier.counts,
            xs, ys, ths, gs, parent, motion, used, blocked)
        queries, reads, voxels = hier.terrain_queries, hier.node_reads, hier.level_counts()
        if found < 0:
            total = int(blocked.sum())
            shares = {c: sum(int(blocked[m]) for m in range(16) if c in constraints_in(m)) for c in Constraint}
            named = tuple(c for c in Constraint if shares[c])
            detail = ", ".join(f"{c.value} {100.0 * shares[c] / max(total, 1):.0f} %" for c in named) or "nothing"
            budget = " (search budget exhausted)" if nstates >= cap else ""
            raise NoAdmissiblePath(f"no admissible path from ({sx:.1f}, {sy:.1f}) to ({gx:.1f}, {gy:.1f}){budget}: "
                                   f"{expansions} states expanded, {total} motions refused by {detail}", named)
        poses, curv = _trace(found, xs, ys, ths, parent, motion, used, dx, dy, dth, kappa)
        levels = _levels(poses, p.features, p.offsets, p.dims, p.resolution, p.shape[0], p.shape[1], a.wheels, a.moments,
                         a.boxes, a.body, a.scalars, hier.meta, hier.cache, hier.touched, hier.cache_offsets,
                         hier.margins, hier.scratch, hier.counts)
        poses[:, 0] += p.origin_x
        poses[:, 1] += p.origin_y
        poses[:, 2] = wrap_angle(poses[:, 2])
        length = float(np.hypot(*np.diff(poses[:, :2], axis=0).T).sum())
        ny, nx = p.shape
        step = np.diff(poses[:, :2], axis=0)
        along = step[:, 0] * np.cos(poses[1:, 2]) + step[:, 1] * np.sin(poses[1:, 2])
        direction = np.concatenate([[1.0], np.where(along < 0.0, -1.0, 1.0)])
        if len(direction) > 1:
            direction[0] = direction[1]
        return CrossCountryPlan(poses, curv, levels, length, queries, reads, voxels, ny * nx * s.headings,
                                int(expansions), int(nstates), (time.perf_counter() - t0) * 1e3, direction)

    def _check_goal(self, gx: float, gy: float, gth: float) -> None:
        s, hier = self.settings, self.hierarchy
        if s.goal_heading_tolerance is not None:
            tries = [gth]
        else:
            tries = [2.0 * math.pi * (t + 0.5) / s.headings for t in range(s.headings)]
        why: set[Constraint] = set()
        for th in tries:
            state, _, against = hier.classify(gx, gy, th)
            if state == ADMISSIBLE:
                return
            why.update(against)
        named = tuple(c for c in Constraint if c in why)
        raise InadmissibleGoal(f"no configuration at the goal ({gx:.2f}, {gy:.2f}) is admissible: {_names(named)}", named)


def _names(constraints: tuple[Constraint, ...]) -> str:
    return ", ".join(c.value for c in constraints) or "undecided"


def _motions(vehicle: TerrainVehicle, s: CrossCountrySettings) -> tuple[np.ndarray, ...]:
    """Return the motions from a state as samples in `vehicle` at its start: dx, dy, dθ (m, q), count (m,), cost (m,), curvature (m,)."""
    radius = vehicle.min_turning_radius if vehicle.steering == "ackermann" else s.skid_turning_radius
    kmax = 1.0 / radius
    kappas = [0.0] if s.arcs == 1 else list(np.linspace(-kmax, kmax, s.arcs))
    m = int(math.ceil(s.step / s.sample - 1e-9))
    rows = []
    for k in kappas:
        d = s.step * np.arange(1, m + 1) / m
        if abs(k) < 1e-12:
            rows.append((d, np.zeros(m), np.zeros(m), s.step, 0.0))
        else:
            rows.append((np.sin(k * d) / k, (1.0 - np.cos(k * d)) / k, k * d, s.step * (1.0 + s.turn_cost * abs(k)), k))
    if s.reverse_cost is not None:
        for k in kappas:
            d = -s.step * np.arange(1, m + 1) / m
            if abs(k) < 1e-12:
                rows.append((d, np.zeros(m), np.zeros(m), s.step * s.reverse_cost, 0.0))
            else:
                rows.append((np.sin(k * d) / k, (1.0 - np.cos(k * d)) / k, k * d,
                             s.step * s.reverse_cost * (1.0 + s.turn_cost * abs(k)), k))
    if vehicle.steering == "skid":
        # Turning in place: heading samples no farther apart than a sample's arc turns at the tightest radius.
        mr = int(math.ceil(s.turn_in_place / (s.sample * kmax) - 1e-9))
        for sign in (1.0, -1.0):
            a = sign * s.turn_in_place * np.arange(1, mr + 1) / mr
            rows.append((np.zeros(mr), np.zeros(mr), a, s.turn_cost * s.turn_in_place, sign * math.inf))
    width = max(len(r[0]) for r in rows)
    dx, dy, dth = (np.zeros((len(rows), width)) for _ in range(3))
    for i, r in enumerate(rows):
        q = len(r[0])
        dx[i, :q], dy[i, :q], dth[i, :q] = r[0], r[1], r[2]
    n = np.array([len(r[0]) for r in rows], np.int64)
    return dx, dy, dth, n, np.array([r[3] for r in rows]), np.array([r[4] for r in rows])


@njit(cache=True, nogil=True, boundscheck=False)
def _to_go(x: float, y: float, gx: float, gy: float, togo: np.ndarray, size: float) -> float:
    """Return the heuristic at (x, y) [m]: the larger of the straight line and the coarse distance to go."""
    d = math.hypot(gx - x, gy - y)
    i, j = int(y / size), int(x / size)
    if 0 <= i < togo.shape[0] and 0 <= j < togo.shape[1]:
        return max(d, togo[i, j])
    return d


@njit(cache=True, nogil=True, boundscheck=False)
def _search(sx: float, sy: float, sth: float, gx: float, gy: float, gth: float, tol: float, th_tol: float,
            dx: np.ndarray, dy: np.ndarray, dth: np.ndarray, n: np.ndarray, cost: np.ndarray, cell: float, nth: int,
            weight: float, togo: np.ndarray, togo_size: float, feat: np.ndarray, offsets: np.ndarray, dims: np.ndarray, res: float, ny: int, nx: int,
            wheels: np.ndarray, moments: np.ndarray, boxes: np.ndarray, body: np.ndarray, sc: np.ndarray,
            meta: np.ndarray, cache: np.ndarray, touched: np.ndarray, coff: np.ndarray, margins: np.ndarray,
            scratch: np.ndarray, counts: np.ndarray, xs: np.ndarray, ys: np.ndarray, ths: np.ndarray, gs: np.ndarray, parent: np.ndarray,
            motion: np.ndarray, used: np.ndarray, blocked: np.ndarray) -> tuple[int, int, int]:
    """Weighted hybrid A* from (sx, sy, sth) to within `tol` [m] (and `th_tol` [rad] if ≥ 0) of (gx, gy, gth).

    Positions from the grid's origin [m]. Returns (the goal state's index or −1, states generated,
    states expanded); the states' poses, costs, parents, motions and the samples of the motion used
    (fewer than all when it passed through the goal) are written into the arrays of length
    `max_states`, and `blocked[bits]` counts the motions refused, by the constraints against.
    """
    cap = xs.shape[0]
    cols = int(nx * res / cell) + 1
    width = 2.0 * math.pi / nth
    best = Dict.empty(key_type=types.int64, value_type=types.float64)
    closed = Dict.empty(key_type=types.int64, value_type=types.int64)
    xs[0], ys[0], ths[0], gs[0], parent[0], motion[0], used[0] = sx, sy, sth % (2.0 * math.pi), 0.0, -1, -1, 0
    heap = [(weight * _to_go(sx, sy, gx, gy, togo, togo_size), 0)]
    states = 1
    expanded = 0
    while len(heap) > 0:
        f, cur = heapq.heappop(heap)
        x, y, th = xs[cur], ys[cur], ths[cur]
        key = (int(y / cell) * cols + int(x / cell)) * nth + min(int(th / width), nth - 1)
        if key in closed:
            continue
        closed[key] = 1
        expanded += 1
        c, s = math.cos(th), math.sin(th)
        for m in range(n.shape[0]):
            ok = True
            arrived = False
            px = py = pth = 0.0
            for q in range(n[m]):
                px, py = x + c * dx[m, q] - s * dy[m, q], y + s * dx[m, q] + c * dy[m, q]
                pth = (th + dth[m, q]) % (2.0 * math.pi)
                state, level, bits = classify_pose(px, py, pth, feat, offsets, dims, res, ny, nx, wheels, moments, boxes,
                                                   body, sc, meta, cache, touched, coff, margins, scratch, counts)
                if state != ADMISSIBLE:
                    blocked[bits] += 1
                    ok = False
                    break
                # A motion passing through the goal region ends there (the search need not land on it).
                if math.hypot(gx - px, gy - py) <= tol and (
                        th_tol < 0.0 or abs((pth - gth + math.pi) % (2.0 * math.pi) - math.pi) <= th_tol):
                    if states >= cap:
                        return -1, states, expanded
                    xs[states], ys[states], ths[states], gs[states] = px, py, pth, gs[cur] + cost[m] * (q + 1) / n[m]
                    parent[states], motion[states], used[states] = cur, m, q + 1
                    arrived = True
                    break
            if arrived:
                return states, states + 1, expanded
            if not ok:
                continue
            nkey = (int(py / cell) * cols + int(px / cell)) * nth + min(int(pth / width), nth - 1)
            if nkey in closed:
                continue
            g = gs[cur] + cost[m]
            if nkey in best and best[nkey] <= g:
                continue
            if states >= cap:
                return -1, states, expanded
            best[nkey] = g
            xs[states], ys[states], ths[states], gs[states], parent[states], motion[states] = px, py, pth, g, cur, m
            used[states] = n[m]
            heapq.heappush(heap, (g + weight * _to_go(px, py, gx, gy, togo, togo_size), states))
            states += 1
    return -1, states, expanded


@njit(cache=True, nogil=True, boundscheck=False)
def _trace(last: int, xs: np.ndarray, ys: np.ndarray, ths: np.ndarray, parent: np.ndarray, motion: np.ndarray,
           used: np.ndarray, dx: np.ndarray, dy: np.ndarray, dth: np.ndarray, kappa: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the path to state `last`: (n, 3) float64 poses (x, y from the grid's origin [m], θ [rad]) and (n,) curvature [1/m]."""
    count = 1
    cur = last
    while parent[cur] >= 0:
        count += used[cur]
        cur = parent[cur]
    poses = np.empty((count, 3))
    curv = np.zeros(count)
    end = count
    cur = last
    while parent[cur] >= 0:
        prev, m = parent[cur], motion[cur]
        c, s = math.cos(ths[prev]), math.sin(ths[prev])
        start = end - used[cur]
        for q in range(used[cur]):
            poses[start + q, 0] = xs[prev] + c * dx[m, q] - s * dy[m, q]
            poses[start + q, 1] = ys[prev] + s * dx[m, q] + c * dy[m, q]
            poses[start + q, 2] = ths[prev] + dth[m, q]
            curv[start + q] = kappa[m]
        end = start
        cur = prev
    poses[0, 0], poses[0, 1], poses[0, 2] = xs[cur], ys[cur], ths[cur]
    return poses, curv


@njit(cache=True, nogil=True, boundscheck=False)
def _levels(poses: np.ndarray, feat: np.ndarray, offsets: np.ndarray, dims: np.ndarray, res: float, ny: int, nx: int,
            wheels: np.ndarray, moments: np.ndarray, boxes: np.ndarray, body: np.ndarray, sc: np.ndarray,
            meta: np.ndarray, cache: np.ndarray, touched: np.ndarray, coff: np.ndarray, margins: np.ndarray,
            scratch: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Return the (n,) int8 level that certified each pose: from the cache the search filled (a configuration that
    reached below level 0 was decided by itself: −1), classified afresh only where the cache holds no answer."""
    out = np.empty(poses.shape[0], np.int8)
    for i in range(poses.shape[0]):
        level = cached_level(poses[i, 0], poses[i, 1], poses[i, 2] % (2.0 * math.pi), dims, res, ny, nx, meta, cache, coff)
        if level != NOT_CACHED:
            out[i] = level
            continue
        state, level, bits = classify_pose(poses[i, 0], poses[i, 1], poses[i, 2] % (2.0 * math.pi), feat, offsets, dims,
                                           res, ny, nx, wheels, moments, boxes, body, sc, meta, cache, touched, coff,
                                           margins, scratch, counts)
        out[i] = level
    return out
