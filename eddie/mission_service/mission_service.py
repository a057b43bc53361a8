"""EDDIE's mission service: takes missions on the CAPTAIN's keys, keeps their status, and (without vision) drives the route.

`python -m eddie.mission_service --map FILE --vehicle V --start-pose X,Y,YAW [--perception on|off]`

EDDIE (seed: Navlab 1990 ch. 3) has no CAPTAIN on a blackboard: a mission is compiled into trigger
annotations on the annotated map, and the modules the triggers wake drive it. This small module is
what `sidewalk submit` talks to. Every mission it accepts it compiles into trigger annotations along its
route (`eddie.missions`: speeds, dead reckoning through intersections, landmarks, the stop at the
destination object) and hands them to the map manager (`MissionAnnotations` on its `mission` service)
before the mission starts — at once when nothing runs, else when the mission's turn comes. It answers the CAPTAIN's mission submit / status / cancel keys with
the CAPTAIN's wire forms and publishes every status change on the mission events stream, so tools
work unchanged for both architectures. Each step's outcome is judged from the believed pose (see
`eddie.mission_service.mission_progress`). With `--perception off` it drives: it sends the whole route,
moved into `local` by the navigator's `world` ← `local`, to the controller as one path (the seed's
dead reckoning along a known route), with each step's speed limit; with perception on, vision road
following drives: this module wakes it when a mission starts and puts it to sleep when the mission
ends, stopping the vehicle unless the mission succeeded (a failed or cancelled mission's stop holds).
"""

from __future__ import annotations

import json
import logging

import numpy as np

from eddie.annotated_map.geojson_file import annotations_to_geojson
from eddie.errors import EddieError
from eddie.messages.controller import PathCommand, Stop
from eddie.messages.map_manager import MissionAnnotations, MissionInstalled
from eddie.missions import MissionCompileError, compile_mission
from eddie.missions.lane import KERB_MARGIN_M
from eddie.messages.modules import MissionRoute, ModuleSwitch, ObstacleSeen
from eddie.obstacle_stop.obstacle_stop_module import CLIENT as OBSTACLE_CLIENT
from eddie.mission_service.mission_progress import MissionProgress, MissionRouteError, mission_route, step_goals
from eddie.modules.sensing import Belief
from eddie.toolkit.module import Incoming
from eddie.toolkit.module import Module
from modules.captain.missionfile import MissionFileError, parse_mission, rejection_from
from modules.pilot import pilot_config_for
from modules.map_navigator import MapData
from modules.vocabulary import MissionStatus, Waiting
from runtime.mission_desk import MissionDesk, MissionRejected
from wire.keys import MissionKeys
from wire.mission import Rejection
from wire.se2 import inverse, transform_points

__all__ = ["MissionService"]

log = logging.getLogger("eddie.mission_service.mission_service")

#: the client name and priority the mission service drives the controller with (vision road following: higher)
CLIENT, PRIORITY = "mission_service", 1


class MissionService:
    """Missions in, statuses out, on the CAPTAIN's keys (the mission desk's room); one mission at a time, the others queued."""

    #: how the desk's rejections name this service
    noun = "mission service"

    def __init__(self, m: Module, map_data: MapData, *, vehicle: str, perception: bool,
                 world_from_local: tuple[float, float, float], tick_s: float = 0.2, speed_mps: float = 1.0,
                 map_manager: str = "map_manager") -> None:
        self.m = m
        self.map_manager = map_manager
        #: each accepted mission's trigger annotations (GeoJSON text), until the map manager holds them
        self._annotations: dict[str, MissionAnnotations] = {}
        #: whether a mission ran already (a later one's route starts where the vehicle is believed to be)
        self._moved = False
        self.map = map_data
        self.vehicle = vehicle
        self.perception = perception
        self.belief = Belief(m, world_from_local)
        self.running: MissionProgress | None = None
        self.tick_s = tick_s
        self.speed_mps = speed_mps
        nav = pilot_config_for(vehicle).navigator
        #: a kept side is driven at most this far off the centre [m], leaving this inside the road's edge [m]
        self.keep_offset_m, self.edge_keep_m = nav.keep_offset, nav.obstacle_clearance + KERB_MARGIN_M
        self.desk: MissionDesk[MissionProgress] = MissionDesk(m.link, MissionKeys(m.net.namespace), self, self._now)
        #: obstacle stop's newest verdict (its `seen` stream), to say what a hold is for
        self._seen: ObstacleSeen | None = None
        m.subscribe("obstacle_stop", "seen", ObstacleSeen, self._on_seen)

    # ---- what the modules believe --------------------------------------------------------

    def believed(self) -> tuple[float, float] | None:
        """Return the believed position (x, y) [m] in `world`: world←local ∘ the controller's local pose."""
        p = self.belief.world()
        return None if p is None else (float(p[0]), float(p[1]))

    def _route_points(self, prog: MissionProgress, *, in_lane: bool = False
                      ) -> tuple[list[tuple[float, float]], list[float], list[float]]:
        """Return the running mission's route, speeds and lane offsets (`mission_route`); `in_lane`: the points moved by them."""
        return mission_route(self.map, prog.goals, prog.run.mission.steps, speed_mps=self.speed_mps, keep_offset_m=self.keep_offset_m,
                             edge_keep_m=self.edge_keep_m, in_lane=in_lane)

    async def on_route(self, _inc: Incoming) -> MissionRoute:
        """Answer `route`: the running mission's route in `world` (vision road following plans along it)."""
        prog = self.running
        if prog is None:
            return MissionRoute()
        pts, speeds, offsets = self._route_points(prog)
        return MissionRoute(mission_id=prog.status.mission_id, points=tuple(pts), speeds=tuple(speeds), offsets=tuple(offsets),
                            state="finished" if prog.status.terminal else "running")

    # ---- the CAPTAIN's keys --------------------------------------------------------------

    def _now(self) -> float:
        return self.m.now() or 0.0

    async def admit(self, payload: bytes) -> MissionProgress:
        """Return a submitted mission (YAML or JSON text) with its step goals and trigger annotations; raise MissionRejected."""
        try:
            mission = parse_mission(payload, source="submitted mission")
        except MissionFileError as exc:
            raise MissionRejected(rejection_from(exc)) from None
        mission = mission.model_copy(update={"mission_id": self.desk.unique_id(mission.mission_id, mission.name)})
        start = self.believed() or (float(self.belief.world_from_local[0]), float(self.belief.world_from_local[1]))
        try:
            goals = step_goals(self.map, start, mission, vehicle=self.vehicle)
            compiled = compile_mission(mission, self.map, vehicle=self.vehicle, start=start if self._moved else None)
        except (MissionRouteError, MissionCompileError) as exc:
            raise MissionRejected(Rejection(error="no_route", message=str(exc))) from None
        self._annotations[mission.mission_id] = MissionAnnotations(
            mission_id=mission.mission_id, name=mission.name,
            geojson=json.dumps(annotations_to_geojson(compiled.annotations, name=mission.mission_id)))
        return MissionProgress(mission, goals, submitted_at=self._now(), stops_at_steps=self.perception)

    async def accepted(self, prog: MissionProgress, ahead: int) -> None:
        """Install the mission's triggers at once when nothing runs before it (a lock-step run is held until then)."""
        if not ahead:
            await self._install(prog.status.mission_id)
        m = prog.run.mission
        log.info("accepted mission %s (%s, %d steps)", m.mission_id, m.name, len(m.steps))

    async def stored(self, prog: MissionProgress) -> None:
        """Nothing to keep besides the events stream: EDDIE has no blackboard."""

    async def cancel_running(self, prog: MissionProgress, reason: str) -> None:
        """Cancel the running mission at once and stop the vehicle."""
        prog.cancel(self._now(), reason)
        await self.m.send("controller", Stop(client=CLIENT, priority=PRIORITY, reason=reason))
        await self.desk.publish(prog)

    def waiting(self) -> Waiting:
        """Return why the vehicle is not driving on what vision sees, from the controller's newest state ("": it is).

        Obstacle stop holding the controller stopped or capped at 0 → "obstacle hold"; the controller
        following a recorded path, or the mission service driving the route without vision → "dead reckoning";
        no path to track yet → "planning".
        """
        b = self.belief
        if b.client == OBSTACLE_CLIENT and (b.mode == "stopped" or b.speed_limit == 0.0):
            return "obstacle hold"
        if b.mode == "dead_reckon" or (not self.perception and b.mode == "tracking"):
            return "dead reckoning"
        if b.mode == "idle":
            return "planning"
        return ""

    def _on_seen(self, seen: ObstacleSeen) -> None:
        self._seen = seen

    def why_waiting(self) -> str:
        """Return `waiting()` with obstacle stop's newest verdict when it holds the vehicle ("": not waiting)."""
        w = self.waiting()
        seen = self._seen
        if w == "obstacle hold" and seen is not None and seen.blocked and seen.distance_m is not None:
            return f"obstacle hold (obstacle stop sees something {seen.distance_m:.1f} m ahead on the path at {seen.stamp:.1f} s)"
        return w

    def answered(self, prog: MissionProgress) -> MissionStatus:
        """Return `prog`'s status as a status query is answered: with where it is when it runs (`StepProgress`)."""
        st = prog.status
        if st.state == "running":
            pose = self.belief.world()
            st = st.model_copy(update={"progress": prog.progress(
                self._now(), None if pose is None else (float(pose[0]), float(pose[1]), float(pose[2])), self.waiting())})
        return st

    # ---- running -------------------------------------------------------------------------

    async def _install(self, mission_id: str) -> None:
        """Hand mission `mission_id`'s annotations to the map manager (once); without one, the mission runs without triggers."""
        msg = self._annotations.pop(mission_id, None)
        if msg is None:
            return
        try:
            ok = await self.m.request(self.map_manager, "mission", msg, timeout=10.0, reply_type=MissionInstalled)
            log.info("mission %s: %d annotations with the map manager", mission_id, ok.count)
        except EddieError as exc:
            log.warning("mission %s runs without its triggers: %s", mission_id, exc)

    async def _drive(self, prog: MissionProgress) -> None:
        """Send the whole route, in `local`, to the controller (no vision: dead reckoning on the map)."""
        pts, speeds, _ = self._route_points(prog, in_lane=True)
        local = transform_points(inverse(self.belief.world_from_local), np.asarray(pts))
        await self.m.send("controller", PathCommand(client=CLIENT, priority=PRIORITY, mode="immediate",
                                                    points=tuple((float(x), float(y)) for x, y in local),
                                                    speed=self.speed_mps, speeds=tuple(speeds)))

    async def run(self) -> None:
        """Declare the keys, then sequence missions one at a time until cancelled."""
        self.desk.declare()
        self.m.serve("route", self.on_route)
        self.m.ready()
        await self.m.clock.wait_running()
        while True:
            prog = await self.desk.next()
            self.running = prog
            self._moved = True
            await self._install(prog.status.mission_id)
            prog.start(self._now())
            await self.desk.publish(prog)
            mid = prog.status.mission_id
            if self.perception:
                await self.m.send("road_following", ModuleSwitch(on=True, mission_id=mid, reason=f"mission {mid} started"))
            else:
                await self._drive(prog)
            while not prog.status.terminal:
                await self.m.clock.sleep(self.tick_s)
                pose = self.belief.world()
                b = self.belief
                odom = None if b.local is None or b.local_stamp is None else (
                    float(b.local_stamp), float(b.local[0]), float(b.local[1]), float(b.local[2]))
                if prog.update(self._now(), None if pose is None else (float(pose[0]), float(pose[1])),
                               None if pose is None else float(pose[2]), odom, self.why_waiting()):
                    await self.desk.publish(prog)
            await self._end(prog)

    async def _end(self, prog: MissionProgress) -> None:
        """Stop driving for a mission that ended: vision put to sleep, the vehicle stopped unless it succeeded under vision.

        Vision road following drives while a mission runs with perception on: woken when it starts, put
        to sleep when it ends (its paths, at a higher priority, would otherwise undo the end's stop). A
        mission that succeeded under vision drives out the path it was given (it ends at the route's end).
        """
        state, mid = prog.status.state, prog.status.mission_id
        if self.perception:
            await self.m.send("road_following", ModuleSwitch(on=False, mission_id=mid, reason=f"mission {mid} {state}"))
        if self.perception and state == "succeeded":
            return
        stop = Stop(client=CLIENT, priority=PRIORITY, reason=f"mission {state}")
        await self.m.send("controller", stop)
        if self.perception:
            # a path vision sent before the switch reached it may reach the controller after the stop
            await self.m.clock.sleep(self.tick_s)
            await self.m.send("controller", stop)
