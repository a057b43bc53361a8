"""Vision road following as an EDDIE process: sees the road, plans in `local`, sends paths to the controller.

`python -m eddie.road_following --vehicle V --map FILE --start-pose X,Y,YAW [--seed N]
[--road-method perception|scarf|yarf|alvinn] [--alvinn-weights FILE]`

It sleeps until a trigger wakes it (`ModuleSwitch(on=True)` in its inbox: "resume vision after
intersection", "use vision through intersection") and goes back to sleep on `ModuleSwitch(on=False)`
("dead reckon through intersection"). The mission service wakes it when a mission starts and puts it
to sleep when the mission ends (so a failed or cancelled mission's stop holds); woken for another
mission, it asks for that mission's route. Awake, each cycle: capture a frame (laser + camera, no
truth), note the controller's `local` pose then, segment with PERCEPTION's pipeline on the map
objects in view, send the position the road edges give to the navigator (as PERCEPTION's fixes reach
the PILOT under CODGER), move the road into `local`, plan with the PILOT's planner along the mission's
route (asked from the mission service) and send the path `immediate` with `sensed_at` = the capture stamp (a path
dead-reckoned along the route when vision found no road carries none: no frame's content produced it, as under CODGER).

With `--road-method scarf|yarf|alvinn` (issue 13) the camera image goes to that road follower
instead: SCARF's or YARF's road centre, moved to the route's lane and into `local` by the pose at
capture, is the path (and, with the map's road there, a line fix to the navigator); ALVINN's
steering arc is driven directly (its road point is logged for map reasoning). A trigger that
dead-reckons through an intersection makes the follower start afresh on the next road.
"""

from __future__ import annotations

import asyncio
import logging

import numpy as np

from eddie.messages.controller import ControllerState, DeadReckon, PathCommand
from eddie.messages.modules import MissionRoute, RouteQuery
from eddie.errors import EddieError
from eddie.modules.errors import NoRoadPath
from eddie.landmark_matching.landmark_matching import calibration_fix, fix_message
from eddie.missions.lane import KERB_MARGIN_M, kept_lane_offset, lane_offset, shift_into_lane
from eddie.road_following.dead_reckoning import DeadReckoning
from eddie.road_following.road_following import (RoadFollowingConfig, follower_path, map_road_at, plan_road_path, road_line_fix, route_ahead,
                                          route_lane_offset, route_to_local)
from eddie.modules.sensing import Belief, capture_frame, objects_in_view
from eddie.modules.switched import Switch, run_switched
from eddie.toolkit.message import Message, message_name
from eddie.toolkit.module import Module
from modules.map_navigator import MapData
from modules.road_following import CameraGeometry, RoadFollowingError
from modules.road_following.road_method import CameraRoadFollower
from modules.parallel import VisionPool
from modules.perception import PerceptionPipeline, ResolutionTable, colored_range_image
from modules.perception.monitor import SENSORS
from modules.pilot import LocalPathPlanner, pilot_config_for
from wire.se2 import inverse, transform_points, wrap_angle

__all__ = ["RoadFollowing"]

log = logging.getLogger("eddie.road_following.road_following")

#: the controller client name and priority of vision (above the mission service's dead reckoning)
CLIENT, PRIORITY = "road_following", 2

#: How far past an intersection's exit a dead-reckoned path runs on along the route [m] (the
#: resume-vision gate sits at the exit; a path ending there could stop short of it).
DEAD_RECKON_BEYOND_M = 4.0

#: A follower that saw no road in this many frames in a row bootstraps afresh on the map's road (SCARF, YARF).
REBOOT_AFTER = 3

#: The planner's budget per path [s wall] and [iterations] (the PILOT's is 5 s and 20,000).
PLAN_WALL_S, PLAN_ITERATIONS = 0.5, 4000


class RoadFollowing:
    """The vision road following loop on one module endpoint."""

    def __init__(self, m: Module, map_data: MapData, *, vehicle: str, seed: int, start: tuple[float, float, float],
                 awake: bool = True, cfg: RoadFollowingConfig | None = None, method: str = "perception",
                 alvinn_net=None, keep: str = "centre", vision_workers: int = 1) -> None:
        self.m = m
        self.map = map_data
        # the vehicle's top speed (the PILOT's) unless told otherwise; routes and triggers slow it
        self.cfg = cfg or RoadFollowingConfig(speed_mps=pilot_config_for(vehicle).max_speed)
        self.switch = Switch(awake)
        self.belief = Belief(m, start)
        pool = VisionPool(vision_workers, warm=("modules.perception",)) if vision_workers > 1 else None  # issue 41
        self.pipeline = PerceptionPipeline(ResolutionTable(SENSORS[vehicle]), speed=self.cfg.speed_mps, pool=pool)
        # the PILOT's planner with a budget a control cycle can afford: a path late by seconds of wall
        # (a minute of sim at RTF 20) is worse than dead reckoning along the route until the next frame
        pc = pilot_config_for(vehicle).planner
        #: the farthest [m] a kept side moves the route off the road's centre: the PILOT's keep offset for the vehicle
        self.keep_offset_m = pilot_config_for(vehicle).navigator.keep_offset
        #: what a kept side leaves inside the road's edge [m]: the vehicle's obstacle clearance and a margin, so kerbside
        #: mailboxes stay out of obstacle stop's corridor when the belief is half a metre off across the road
        self.edge_keep_m = pilot_config_for(vehicle).navigator.obstacle_clearance + KERB_MARGIN_M
        self.planner = LocalPathPlanner(pc.model_copy(update={"max_wall_s": PLAN_WALL_S, "max_iterations": min(pc.max_iterations, PLAN_ITERATIONS)}),
                                        seed=seed)
        self.route: MissionRoute | None = None
        self.method = method
        self.follower = None if method == "perception" else CameraRoadFollower(method, alvinn_net=alvinn_net)
        self.lane_offset_m: float | None = None  # the lane's offset from the road centre, set on the follower's first frame
        self.frames = {True: 0, False: 0}
        self._was_found: bool | None = None
        self._lost_run = 0
        self.keep = keep  # the side of the road the mission keeps to (EDDIE's route is the road's centre line)
        self.dead_reckoning = DeadReckoning(CLIENT)
        self.belief.on_state.append(self._on_controller_state)

    def _on_controller_state(self, st: ControllerState) -> None:
        if self.switch.awake or not self.switch.mission_running:
            self.dead_reckoning.ended()
            return
        cmd = self.dead_reckoning.again(st)
        if cmd is not None:
            log.warning("road_following: t=%.2f the controller drives nothing and nobody holds it (restarted, or a hold "
                        "lifted) while dead reckoning through an intersection: the rest of the path sent again (%d points)",
                        st.stamp, len(cmd.points or ()))
            asyncio.ensure_future(self.m.send("controller", cmd)).add_done_callback(_log_send_failure)

    async def _route(self) -> MissionRoute | None:
        try:
            r = await self.m.request("mission_service", "route", RouteQuery(), timeout=2.0, reply_type=MissionRoute)
        except EddieError as exc:
            log.debug("no route: %s", exc)
            return None
        return r if r.state == "running" and len(r.points) >= 2 else None

    def _route_speed(self, world_pose: np.ndarray) -> float:
        """Return the speed [m/s] the route allows where the vehicle is (its nearest route point), capped by `speed_mps`.

        The controller caps it again with the mission's set-speed triggers (slow in intersections).
        """
        r = self.route
        if r is None or not r.speeds:
            return self.cfg.speed_mps
        i = int(np.argmin(np.linalg.norm(np.asarray(r.points) - world_pose[:2], axis=1)))
        return min(self.cfg.speed_mps, float(r.speeds[min(i, len(r.speeds) - 1)]))

    async def cycle(self) -> str:
        """Run one cycle; return what happened (for the log)."""
        sw = self.switch
        if self.route is not None and sw.mission_id and (self.route.mission_id != sw.mission_id or not sw.mission_running):
            # the mission ended (a trigger woke this module since) or another began: ask again, see the road afresh
            self.route = None
            if self.follower is not None:
                self.follower.reset()
            self.lane_offset_m = None
        if self.route is None:
            self.route = await self._route()
            if self.route is None:
                return "no mission route"
        taken = self.switch.taken
        frame = await capture_frame(self.m)
        poses = await self.belief.at_capture(frame.stamp)
        if poses is None:
            return "no controller pose at the capture"
        at_capture, prior = poses
        if self.follower is not None:
            return await self._follower_cycle(frame, at_capture, prior, taken)
        img = colored_range_image(frame, pool=self.pipeline.pool)
        objs = objects_in_view(self.map, tuple(prior))
        # perception and planning run in a worker thread: the loop keeps beating and reading its inbox meanwhile
        out = await asyncio.to_thread(self.pipeline.process, img, objs, tuple(prior), error_allowance=0.5)
        fix = calibration_fix(out, frame.stamp)
        if fix is not None:
            # the road edges and landmarks PERCEPTION matched place the vehicle: the navigator gates and takes it
            await self.m.send("navigator", fix_message(fix, tuple(at_capture), CLIENT))
        local_from_world = tuple(inverse(self.belief.world_from_local))
        route = route_to_local(np.asarray(self.route.points), local_from_world)
        routes = [route]
        if self.route.offsets:
            if any(self.route.offsets):
                # the route is the road's centre line: the mission service gives each step's lane (a quarter of the width,
                # at most the PILOT's keep offset: 1.5 m for the Navlab, 0.3 m for the Terregator on walks with benches
                # beside them) and its goal's lane; where that does not fit the road seen, on the centre
                routes.insert(0, route_to_local(shift_into_lane(np.asarray(self.route.points), np.asarray(self.route.offsets)),
                                                local_from_world))
        elif self.keep != "centre":
            # a route without offsets: the lane of the road where the vehicle is
            road = map_road_at(self.map.world.edges, (float(prior[0]), float(prior[1])), float(prior[2]))
            if road is not None:
                off = kept_lane_offset(self.keep, road.width_m, self.keep_offset_m, self.edge_keep_m)
                routes.insert(0, route_to_local(shift_into_lane(np.asarray(self.route.points), off), local_from_world))
        speed = self._route_speed(prior)
        now = self.belief.local
        try:
            if out.navigable is None:
                raise NoRoadPath(f"no road seen ({out.failure or 'nothing found'})")
            for k, along in enumerate(routes):
                try:
                    path = await asyncio.to_thread(plan_road_path, self.planner, tuple(now), out.navigable, tuple(at_capture), along,
                                                   frame.stamp, self.cfg.model_copy(update={"speed_mps": speed}))
                    break
                except NoRoadPath:
                    if k == len(routes) - 1:
                        raise
        except NoRoadPath as exc:
            # vision lost the road (an intersection, a turn): dead-reckon slowly along the route until it sees it again
            if self.switch.taken != taken or not self.switch.awake:
                return f"{exc}; a trigger came meanwhile"
            ahead = route_ahead(route, now[:2], self.cfg.lookahead_m)
            if len(ahead) < 2:
                return f"{exc}; at the route's end"
            await self.m.send("controller", PathCommand(client=CLIENT, priority=PRIORITY, mode="immediate",
                                                        points=tuple((float(x), float(y)) for x, y in ahead),
                                                        speed=min(self.cfg.blind_speed_mps, speed), sensed_at=None))  # dead reckoned: no frame made it
            return f"{exc}; dead reckoning along the route"
        if self.switch.taken != taken or not self.switch.awake:
            return "a trigger came while perceiving: this path is not sent"  # it may have put vision to sleep
        await self.m.send("controller", PathCommand(client=CLIENT, priority=PRIORITY, mode="immediate",
                                                    points=tuple((p[0], p[1]) for p in path.poses), speed=path.speed_mps,
                                                    sensed_at=path.sensed_at))
        return f"path of {len(path.poses)} poses sent"

    def _tally(self, found: bool, why: str) -> None:
        """Count the follower's frames with and without a road; log when it finds or loses the road."""
        self.frames[found] += 1
        self._lost_run = 0 if found else self._lost_run + 1
        if found != self._was_found:
            log.info("%s: %s (frames with a road %d, without %d)", self.method, "road found" if found else f"road lost: {why}",
                     self.frames[True], self.frames[False])
            self._was_found = found

    async def _follower_cycle(self, frame, at_capture: np.ndarray, prior: np.ndarray, taken: int) -> str:
        """Run one cycle with the road follower (see module docstring); return what happened."""
        assert self.follower is not None and self.route is not None
        route_world = np.asarray(self.route.points)
        road = map_road_at(self.map.world.edges, (float(prior[0]), float(prior[1])), float(prior[2]))
        if self.lane_offset_m is None or self.follower.follower is None or (self._lost_run >= REBOOT_AFTER and self.method != "alvinn"):
            # bootstrap on the map's road where the vehicle believes it is (the seed's one external input: where the road starts);
            # a follower that lost the road for some frames starts afresh the same way (its prior may be from a turn)
            self.lane_offset_m = 0.0 if road is None else route_lane_offset(route_world, road) + lane_offset(self.keep, road.width_m)
            if road is None:
                self.follower.reset(self.lane_offset_m)
            else:
                # across the road: the lane it is to keep (the belief can be a lane off after dead reckoning through an
                # intersection, and a prior a lane off locks YARF on an edge stripe); along it: the map road's direction
                self.follower.reset(self.lane_offset_m, wrap_angle(road.direction_rad - prior[2]))
                self.follower.road_width_m = road.width_m
            self._lost_run = 0
        lane = self.lane_offset_m  # a trigger may reset it while this cycle waits
        try:
            cam = CameraGeometry.from_capture(frame)
            obs = await asyncio.to_thread(self.follower.observe, frame.camera_image, cam, tuple(at_capture), stamp=frame.stamp,
                                          speed_mps=self.belief.speed)
        except RoadFollowingError as exc:
            return f"{self.method}: {exc}"
        if obs.road_point is not None:
            log.debug("%s: road point %.2f, %.2f m (vehicle) at %.2f s", self.method, *obs.road_point, frame.stamp)
        if road is not None:
            fix = road_line_fix(obs, road, tuple(at_capture), frame.stamp, source=CLIENT)
            if fix is not None and obs.confidence >= 0.5:
                await self.m.send("navigator", fix)
        route = route_to_local(route_world, tuple(inverse(self.belief.world_from_local)))
        speed = self._route_speed(prior)
        now = self.belief.local
        try:
            pts = follower_path(obs, tuple(at_capture), tuple(now), route, self.cfg, lane_offset_m=lane,
                                max_off_route_m=3.5 + abs(lane))
            self._tally(True, "")
        except NoRoadPath as exc:
            self._tally(False, str(exc))
            if self.switch.taken != taken or not self.switch.awake:
                return f"{exc}; a trigger came meanwhile"
            # in the lane the follower kept: the route is the road's centre line
            kept = lane - (route_lane_offset(route_world, road) if road is not None else 0.0)
            along = route if kept == 0.0 else route_to_local(shift_into_lane(route_world, kept), tuple(inverse(self.belief.world_from_local)))
            ahead = route_ahead(along, now[:2], self.cfg.lookahead_m)
            if len(ahead) < 2:
                return f"{exc}; at the route's end"
            await self.m.send("controller", PathCommand(client=CLIENT, priority=PRIORITY, mode="immediate",
                                                        points=tuple((float(x), float(y)) for x, y in ahead),
                                                        speed=min(self.cfg.blind_speed_mps, speed), sensed_at=None))  # dead reckoned: no frame made it
            return f"{exc}; dead reckoning along the route"
        if self.switch.taken != taken or not self.switch.awake:
            return "a trigger came while following: this path is not sent"
        await self.m.send("controller", PathCommand(client=CLIENT, priority=PRIORITY, mode="immediate",
                                                    points=tuple((float(x), float(y)) for x, y in pts), speed=speed,
                                                    sensed_at=frame.stamp))
        return f"{self.method}: path of {len(pts)} points sent (confidence {obs.confidence:.2f}, {obs.ms_per_frame:.0f} ms)"

    async def on_trigger(self, data: Message) -> None:
        """Act on a trigger's data: dead-reckon through an intersection along its points, or cap the speed."""
        kind = message_name(data)
        if kind == "map_manager.dead_reckon_through":
            if self.follower is not None:
                self.follower.reset()  # the road after the intersection is a new one: bootstrap afresh
                self.lane_offset_m = None
            local = transform_points(inverse(self.belief.world_from_local), np.asarray(data.points))  # type: ignore[attr-defined]
            if self.route is not None:
                # run on along the route past the exit, so the vehicle crosses the gate that resumes vision
                route = route_to_local(np.asarray(self.route.points), tuple(inverse(self.belief.world_from_local)))
                beyond = route_ahead(route, local[-1], DEAD_RECKON_BEYOND_M)
                local = np.vstack([local, beyond[1:]]) if len(beyond) >= 2 else local
            cmd = DeadReckon(client=CLIENT, priority=PRIORITY, mode="immediate",
                             points=tuple((float(x), float(y)) for x, y in local), speed=float(data.speed))  # type: ignore[attr-defined]
            await self.m.send("controller", cmd)
            self.dead_reckoning.sent(cmd)
        elif kind == "map_manager.set_speed":
            self.cfg = self.cfg.model_copy(update={"speed_mps": max(float(data.speed), 0.1)})  # type: ignore[attr-defined]

    async def run(self) -> None:
        """Sleep until woken, then run cycles while awake; the inbox and the triggers switch it."""
        try:
            await run_switched(self.m, self.switch, self.cycle, period_s=0.2, on_data=self.on_trigger)
        finally:
            if self.pipeline.pool is not None:
                self.pipeline.pool.close()


def _log_send_failure(task: asyncio.Future) -> None:
    if not task.cancelled() and task.exception() is not None:
        log.error("road_following: sending the dead-reckoned path again failed: %r", task.exception())
