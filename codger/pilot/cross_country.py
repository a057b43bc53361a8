"""The PILOT across country (Navlab 1990 §2.4 on CODGER): a `cross-country` segment driven on the terrain tiles.

When the route segment is an off-road goal (mode `cross-country`, from the MAP NAVIGATOR's off-road step)
the PILOT plans with the cross-country planner instead of its road planner: it pastes the TERRAIN module's
`terrain_tile` tokens into a terrain map of its own (the segment's corridor), plans from its *estimated*
pose to the goal — or, while the goal lies beyond what the laser has seen, to the best reachable point
toward it at the edge of the known map (the paper's "next sensing point") — and posts the path for the
HELM as a `local_path_plan` like its other paths. It plans again only when new tiles came in (and at most
every `replan_s` of sim time) or when the vehicle nears the end of its path: a lock-step tick with
nothing new does no planning. The step ends by the arrival rule of every segment that stops: the
estimate within the exit radius, then at rest.

  reads   route_segment (mode cross-country), terrain_tile, poses
  writes  local_path_plan, segment_result
"""

from __future__ import annotations

import asyncio
import logging
import math
from dataclasses import dataclass

import numpy as np

from blackboard import Spec
from blackboard.errors import BlackboardError
from modules.pilot.planner import PlannedPath, path_curvature
from modules.terrain.cross_country_planner import CrossCountryPlan, CrossCountryPlanner, CrossCountrySettings
from modules.terrain.errors import InadmissibleGoal, InadmissibleStart, TerrainPlanningError
from modules.terrain.terrain_map import TerrainMap
from modules.terrain.vehicle_model import TerrainVehicle, terrain_vehicle_for
from modules.vocabulary import RouteSegmentDescription, TerrainTile

__all__ = ["CROSS_COUNTRY_MODE", "CrossCountryDriving", "CrossCountryOptions", "plans_on_terrain", "frontier_goals", "planned_path", "first_leg", "retreat_path", "stop_path"]

log = logging.getLogger(__name__)

#: The navigation mode of a segment the PILOT drives on the terrain tiles.
CROSS_COUNTRY_MODE = "cross-country"


def plans_on_terrain(seg: RouteSegmentDescription) -> bool:
    """Return whether the PILOT drives `seg` with the cross-country planner on terrain tiles (else its road planner)."""
    return seg.mode == CROSS_COUNTRY_MODE


@dataclass(frozen=True)
class CrossCountryOptions:
    """How the PILOT drives across country: re-planning [s] sim, frontier goals [m], [rad], the planner's settings.

    A plan is re-made when tiles arrive (at most every `replan_s`), within `near_end_m` of its end, or when the
    vehicle has not moved for `stall_s`; a manoeuvre is handed to the HELM one leg at a time, the next planned
    within `leg_end_m` of the leg's end. `trail_m` of the vehicle's own track is kept to back up `retreat_m` on.
    """

    replan_s: float = 1.0
    near_end_m: float = 4.0
    frontier_reach_m: tuple[float, ...] = (16.0, 13.0, 10.0, 7.0, 4.5)
    frontier_bearings: tuple[float, ...] = tuple(math.radians(a) for a in (0.0, 20.0, -20.0, 40.0, -40.0, 65.0, -65.0))
    goal_tolerance_m: float = 0.5
    frontier_tolerance_m: float = 1.5
    frontier_states: int = 15_000
    leg_end_m: float = 0.6
    stall_s: float = 4.0
    trail_m: float = 12.0
    retreat_m: float = 4.0
    max_retreats: int = 6
    # The voxels grown by 0.25 m and 2°: what the HELM's tracking of the Navlab (steering lag, cusps) strays by, besides
    # the sampling; unknown terrain up to 5 % of the body's area, which the coarse nodes the bounds read overlap.
    planner: CrossCountrySettings = CrossCountrySettings(max_unknown_share=0.05, reverse_cost=4.0, position_uncertainty=0.25,
                                                         heading_uncertainty=math.radians(2.0))


def frontier_goals(x: float, y: float, goal: tuple[float, float], opts: CrossCountryOptions) -> list[tuple[float, float]]:
    """Return intermediate goals (x, y) [m] `world` toward `goal` from (x, y), the ones closest to the goal first.

    Each lies `frontier_reach_m` from the vehicle at a bearing off the line to the goal; the planner
    takes the first it can reach (a point the laser has not seen is refused at once by sensing).
    """
    head = math.atan2(goal[1] - y, goal[0] - x)
    to_goal = math.hypot(goal[0] - x, goal[1] - y)
    pts = []
    for r in opts.frontier_reach_m:
        if r >= to_goal:
            continue
        for b in opts.frontier_bearings:
            px, py = x + r * math.cos(head + b), y + r * math.sin(head + b)
            pts.append((math.hypot(goal[0] - px, goal[1] - py), px, py))
    pts.sort()
    return [(px, py) for _, px, py in pts]


def planned_path(plan: CrossCountryPlan, vehicle: TerrainVehicle) -> PlannedPath:
    """Return the planner's path as the PILOT's path: poses (n, 3) of the vehicle's pose frame in world (the planner's
    are its reference point's), arc length, direction of the motion *leaving* each pose (±1, the road planner's
    convention), signed curvature."""
    poses = vehicle.origin_of(plan.poses)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
    direction = np.ones(len(poses))
    if plan.direction is not None and len(poses) > 1:
        direction[:-1] = plan.direction[1:]  # the planner's: the motion *reaching* each pose
        direction[-1] = direction[-2]
    return PlannedPath(poses=poses, s=s, direction=direction, curvature=path_curvature(poses) * direction)


def first_leg(path: PlannedPath) -> PlannedPath:
    """Return `path` up to its first change of direction (all of it when it has none): the HELM drives one leg at a time."""
    change = np.flatnonzero(path.direction[1:-1] != path.direction[:-2])
    if not len(change):
        return path
    n = int(change[0]) + 2  # through the pose where the direction changes
    direction = path.direction[:n].copy()
    direction[-1] = direction[-2]
    return PlannedPath(poses=path.poses[:n], s=path.s[:n], direction=direction, curvature=path.curvature[:n])


def stop_path(pose: tuple[float, float, float], length: float = 0.3) -> PlannedPath:
    """Return a path `length` [m] straight ahead of `pose` (x, y [m], yaw [rad], world) that ends in a stop: the HELM brakes now."""
    x, y, yaw = pose
    poses = np.array([[x, y, yaw], [x + length * math.cos(yaw), y + length * math.sin(yaw), yaw]])
    return PlannedPath(poses=poses, s=np.array([0.0, length]), direction=np.ones(2), curvature=np.zeros(2))


def retreat_path(trail: list[tuple[float, float, float]], length: float) -> PlannedPath | None:
    """Return the path backing up `length` [m] along `trail` (the vehicle's own poses, oldest first, world), or None if it is too short.

    The ground the vehicle just drove over is ground it can stand on, whatever the map says now: when the newest
    tiles make the configuration it stands in inadmissible (a tree's crown seen from under its edge), it retraces
    its track in reverse and plans again from there.
    """
    pts = [trail[-1]]
    run = 0.0
    for p in reversed(trail[:-1]):
        run += math.hypot(p[0] - pts[-1][0], p[1] - pts[-1][1])
        pts.append(p)
        if run >= length:
            break
    if run < 0.5 * length:
        return None
    poses = np.array(pts, np.float64)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
    direction = -np.ones(len(poses))
    return PlannedPath(poses=poses, s=s, direction=direction, curvature=path_curvature(poses) * direction)


class CrossCountryDriving:
    """The PILOT's cross-country part: one segment at a time, on the parts of a running `Pilot`."""

    def __init__(self, pilot, opts: CrossCountryOptions = CrossCountryOptions()) -> None:
        self.pilot = pilot
        self.opts = opts
        self.vehicle = terrain_vehicle_for(pilot.cfg.vehicle)
        self.plans = 0
        self.plan_failures = 0
        self.terrain_queries = 0
        #: the vehicle's own poses (world, oldest first, 0.2 m apart, the last `trail_m`), kept across segments
        self.trail: list[tuple[float, float, float]] = []
        self.retreats = 0

    def _map_for(self, seg: RouteSegmentDescription, resolution: float) -> TerrainMap:
        """Return an empty terrain map over the segment's corridor (its centreline's box grown by half its width)."""
        pts = np.asarray(seg.centreline, np.float64)
        half = seg.width_m / 2.0
        bounds = (float(pts[:, 0].min() - half), float(pts[:, 1].min() - half), float(pts[:, 0].max() + half),
                  float(pts[:, 1].max() + half))
        return TerrainMap(bounds, resolution, self.vehicle)

    async def drive(self, seg_tok):
        """Drive cross-country segment `seg_tok` to its exit; post its result; return a newer segment that pre-empted it."""
        p = self.pilot
        seg: RouteSegmentDescription = seg_tok.attrs
        clock, estimator, monitor, cfg = p.rt.clock, p.estimator, p.monitor, p.cfg
        goal = seg.exit.point
        tiles: asyncio.Queue = asyncio.Queue()
        mon = await p.bb.monitor(Spec(type="terrain_tile")).start()
        pump = asyncio.ensure_future(p._pump(mon, tiles))
        terrain: TerrainMap | None = None
        planner: CrossCountryPlanner | None = None
        sensed_at = -math.inf
        changed = False
        last_plan_t = -math.inf
        path_end: tuple[float, float] | None = None  # where the path posted leaves the vehicle's pose frame, world [m]
        reaches_goal = False
        one_leg = False  # the path posted is one leg of a manoeuvre (it ends where the vehicle changes direction)
        moved_at = (clock.now(), tuple(float(v) for v in estimator.pose[:2]))  # when the vehicle last moved 0.2 m
        start_distance = estimator.distance_m
        last_progress = (clock.now(), math.hypot(goal[0] - estimator.pose[0], goal[1] - estimator.pose[1]))
        log.info("pilot: cross-country segment %s to (%.1f, %.1f), %.0f m", seg.segment_id, goal[0], goal[1], seg.length_m)
        try:
            for tok in sorted(await p.bb.retrieve(Spec(type="terrain_tile")), key=lambda t: t.attrs.sensed_at):
                tiles.put_nowait(tok)
            while not p.rt.stopping:
                now = clock.now()
                if p._stalled():
                    last_progress = (now, last_progress[1])
                await estimator.step()
                change = await monitor.change(seg)
                if change is not None:
                    return change.by
                moved = await p.landmark_fixes()
                await estimator.post(force=moved is not None, source="perception" if moved is not None else "dead-reckoning")
                while not tiles.empty():
                    ev = tiles.get_nowait()
                    tile = getattr(ev, "token", ev).attrs
                    if getattr(ev, "kind", "new") == "deleted" or not isinstance(tile, TerrainTile):
                        continue
                    if terrain is None:
                        terrain = self._map_for(seg, tile.resolution)
                        planner = CrossCountryPlanner(terrain.pyramid, self.vehicle, self.opts.planner)
                    changed = terrain.paste(tile) or changed
                    sensed_at = max(sensed_at, tile.sensed_at)
                x, y, yaw = (float(v) for v in estimator.pose)
                trail = self.trail
                if not trail or math.hypot(x - trail[-1][0], y - trail[-1][1]) >= 0.2:
                    trail.append((x, y, yaw))
                    while len(trail) > 2 and math.hypot(trail[1][0] - x, trail[1][1] - y) > self.opts.trail_m:
                        trail.pop(0)
                if math.hypot(x - moved_at[1][0], y - moved_at[1][1]) >= 0.2:
                    moved_at = (now, (x, y))
                to_goal = math.hypot(goal[0] - x, goal[1] - y)
                if to_goal <= seg.exit.radius_m:
                    # stop here: the path being driven may go on (past the goal, or backing up from a refused start)
                    await p.planner.post(seg, stop_path((x, y, yaw)), estimator.world_from_local(), (), 0.5, True, clock.now())
                    return await p._come_to_rest(seg, f"off-road goal reached ({self.plans} cross-country plans)", start_distance)
                near_end = path_end is not None and not reaches_goal and \
                    math.hypot(path_end[0] - x, path_end[1] - y) < (self.opts.leg_end_m if one_leg else self.opts.near_end_m)
                due = now - last_plan_t >= self.opts.replan_s
                # A leg of a manoeuvre is driven to its end (a new plan from mid-leg would begin the manoeuvre again)
                # unless the vehicle stopped on it.
                driving_leg = one_leg and now - moved_at[0] < self.opts.stall_s
                if planner is not None and due and (path_end is None or near_end or (changed and not driving_leg)
                                                    or now - moved_at[0] >= self.opts.stall_s):
                    t_plan = clock.now()
                    changed = False
                    plan, reaches_goal_now, why, start_refused = await asyncio.to_thread(self._plan, planner, (x, y, yaw), goal)
                    last_plan_t = clock.now()
                    last_progress = (last_progress[0] + max(0.0, last_plan_t - t_plan), last_progress[1])
                    path: PlannedPath | None = None
                    if plan is None:
                        self.plan_failures += 1
                        log.warning("pilot: no cross-country plan from (%.1f, %.1f): %s", x, y, why)
                        path = retreat_path(trail, self.opts.retreat_m) if start_refused and self.retreats < self.opts.max_retreats else None
                        if path is not None:
                            self.retreats += 1
                            log.warning("pilot: backing up %.1f m along the track it came on (%d)", path.length, self.retreats)
                            del trail[len(trail) - len(path.poses) + 1:]
                            reaches_goal, one_leg = False, True
                    else:
                        self.plans += 1
                        self.terrain_queries += plan.terrain_queries
                        path = first_leg(planned_path(plan, self.vehicle))
                        one_leg = path.length < planned_path(plan, self.vehicle).length - 1e-6
                        reaches_goal = reaches_goal_now and not one_leg
                    if path is not None:
                        path_end = (float(path.poses[-1, 0]), float(path.poses[-1, 1]))
                        moved_at = (clock.now(), (x, y))
                        speed = seg.constraints.speed_limit or cfg.max_speed
                        await p.planner.post(seg, path, estimator.world_from_local(), (), speed, True, clock.now(),
                                             sensed_at=sensed_at if math.isfinite(sensed_at) else None)
                if to_goal < last_progress[1] - 0.2:
                    last_progress = (now, to_goal)
                elif now - last_progress[0] > cfg.stuck_timeout_s:
                    await monitor.report(seg, False, f"no progress across country for {cfg.stuck_timeout_s:.0f} s, "
                                                     f"{to_goal:.1f} m from the goal ({self.plan_failures} planning failures)",
                                         start_distance)
                    return None
                await clock.sleep(cfg.tick_s)
            return None
        finally:
            pump.cancel()
            try:
                await mon.close()
            except BlackboardError:
                pass

    def _plan(self, planner: CrossCountryPlanner, pose: tuple[float, float, float],
              goal: tuple[float, float]) -> tuple[CrossCountryPlan | None, bool, str, bool]:
        """Return (a plan to the goal or to the best frontier point, whether it reaches the goal, why none was found,
        whether the configuration the vehicle stands in was refused).

        `pose` is the vehicle's pose frame; the planner's configurations are its reference point, so the goal
        for the reference point lies `reference_ahead` beyond the goal on the line from the vehicle.
        """
        opts = self.opts
        why = ""
        start = self.vehicle.reference_of(*pose)
        ahead = math.atan2(goal[1] - pose[1], goal[0] - pose[0])
        goal = (goal[0] + self.vehicle.reference_ahead * math.cos(ahead), goal[1] + self.vehicle.reference_ahead * math.sin(ahead))
        planner.settings = opts.planner.model_copy(update={"goal_tolerance": opts.goal_tolerance_m})
        try:
            return planner.plan(start, (goal[0], goal[1], 0.0)), True, "", False
        except InadmissibleStart as exc:
            return None, False, str(exc), True
        except TerrainPlanningError as exc:
            why = str(exc)
        planner.settings = opts.planner.model_copy(update={"goal_tolerance": opts.frontier_tolerance_m,
                                                           "max_states": opts.frontier_states})
        for gx, gy in frontier_goals(start[0], start[1], goal, opts):
            try:
                return planner.plan(start, (gx, gy, 0.0)), False, "", False
            except InadmissibleGoal:
                continue
            except InadmissibleStart as exc:
                return None, False, str(exc), True
            except TerrainPlanningError as exc:
                why = str(exc)
        return None, False, why, False
