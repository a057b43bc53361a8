"""Compile a mission into trigger annotations along the route the MAP NAVIGATOR picks (seed §3.3).

For each step, from the previous step's goal (the first from the mission's or the map's start pose),
the route is the MAP NAVIGATOR's `select_route` cut by its `segment_route` (both as libraries, with
the vehicle's turning radius). Out come, in `world` [m]:

- a `route` annotation (no trigger) per route segment, its `RouteSegment` data carrying the speed:
  min(3.0 m/s, the step's limit) on straights, 0.5 m/s in intersections; chained by next / previous id;
- a `set_speed` gate where the speed changes (the step's first straight, and around intersections);
- per intersection the "turn at intersection" macro (`macros`): slow down, stop landmarks and
  obstacle detection, dead-reckon through (or, if asked, vision through), then resume vision,
  restart both and cruise again;
- `start_landmarks` at the start of each step listing the landmarks near its first straight, and
  `start_obstacles` there too (fast obstacle detection sleeps until the route switches it on);
- a `stop_at_object` gate `STOP_LEAD_M` before each step's destination (on a shorter route, `FIRST_GATE_M` into
  it, with the step's first gates), naming the object there
  (for amv-delivery the mailbox) and the step's action (stop / wait / continue); the stop point is
  beside that object (`eddie.missions.destination`), in the step's lane.

The MAP NAVIGATOR's and CAPTAIN's libraries are imported when a mission is compiled, not when this
file is: their packages' `__init__` also import their blackboard services, and importing `eddie`
(the map manager process included) must load no blackboard code. Compiling is offline
(`sidewalk eddie annotate`); only the annotated map file reaches the running EDDIE system.
"""

from __future__ import annotations

import math
from pathlib import Path

import shapely
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict
from wire.mapfile import WorldFileError

from modules.vocabulary import Mission

from eddie.annotated_map.annotation import Annotation, Location
from eddie.messages.map_manager import (LandmarkMatching, ObstacleDetection, RouteSegment, SetSpeed, StopAtObject,
                                        encode_trigger_data)
from eddie.missions.errors import MissionCompileError
from eddie.missions.destination import STOP_LEAD_M, destination_object, destination_point
from eddie.missions.lane import lane_goal
from eddie.missions.macros import gate, trigger, turn_at_intersection

if TYPE_CHECKING:
    from modules.map_navigator.mapdata import MapData

__all__ = ["CRUISE_SPEED_M_S", "INTERSECTION_SPEED_M_S", "STOP_LEAD_M", "LANDMARK_RADIUS_M", "CompiledMission",
           "compile_mission", "compile_mission_files"]

#: The seed's AMV profile: up to 3.0 m/s on straights, 0.5 m/s in intersections.
CRUISE_SPEED_M_S = 3.0
INTERSECTION_SPEED_M_S = 0.5
#: Landmarks within this distance [m] of a straight are listed for landmark matching on it.
LANDMARK_RADIUS_M = 12.0
#: How far into a step its first gates sit [m] (a gate under the start would fire at the first cycle anyway).
FIRST_GATE_M = 1.0
_INTERSECTIONS = ("turn-at-intersection", "go-through-intersection")
#: How far before stairs fast obstacle detection is switched off [m]: obstacle stop's reach along the path
#: (`eddie.obstacle_stop.ObstacleStopConfig.stop_distance_m`, 15 m) and a margin. Risers are what the laser sees of
#: stairs; without this the vehicle stood at their foot, held for "something 4.5 m ahead on the path" (issue 37).
STAIRS_OBSTACLE_LEAD_M = 17.0


class CompiledMission(BaseModel):
    """A mission compiled over a map: its name, the vehicle, the annotations in driving order."""

    model_config = ConfigDict(frozen=True)

    mission: str
    map_name: str
    vehicle: str
    annotations: tuple[Annotation, ...]


def _landmarks(m: "MapData", coords: Any) -> tuple[str, ...]:
    line = shapely.LineString(coords)
    return tuple(o.id for _d, o in m.objects_near(line, LANDMARK_RADIUS_M) if o.role == "landmark")


def compile_mission(mission: Mission, m: "MapData", *, vehicle: str | None = None,
                    intersections: str = "dead_reckon", start: tuple[float, float] | None = None) -> CompiledMission:
    """Return the annotations of `mission` over map `m`; raise MissionCompileError naming the step.

    `intersections`: `dead_reckon` (the seed's AMV: dead-reckon through, resume vision after) or `vision`
    (vision through intersections). The route starts at the mission's start, else `start` (x, y) [m] `world`
    (where the vehicle is believed to be), else the map's start.
    """
    if intersections not in ("dead_reckon", "vision"):
        raise MissionCompileError(f"intersections: {intersections!r}: expected dead_reckon or vision")
    from modules.map_navigator.route import RouteError, RouteOptions, select_route
    from modules.map_navigator.segments import SegmentOptions, segment_route
    from modules.map_navigator.stepjob import vehicle_turn_radius

    veh = vehicle or mission.vehicle or "terregator"
    if mission.start is not None:
        here = (mission.start.x, mission.start.y)
    elif start is not None:
        here = (float(start[0]), float(start[1]))
    elif m.world.start is not None:
        here = (m.world.start.x, m.world.start.y)
    else:
        raise MissionCompileError(f"mission {mission.name!r}: no start pose (the mission gives none and map {m.name!r} has none)")
    seg_opts = SegmentOptions(turn_radius_m=vehicle_turn_radius(veh))
    out: list[Annotation] = []
    routes: list[Annotation] = []
    speed_now: float | None = None
    seg_index = 0
    for k, step in enumerate(mission.steps):
        try:
            route = select_route(m, here, step.destination, step.constraints, RouteOptions(vehicle=veh))  # type: ignore[arg-type]
        except RouteError as exc:
            raise MissionCompileError(f"mission {mission.name!r} step {k + 1} ({step.name}): {exc}") from None
        plans = segment_route(route, m, seg_opts)
        if not plans:
            raise MissionCompileError(f"mission {mission.name!r} step {k + 1} ({step.name}): empty route")
        cruise = min(CRUISE_SPEED_M_S, step.constraints.speed_limit or CRUISE_SPEED_M_S)
        slow = min(INTERSECTION_SPEED_M_S, cruise)
        pts: list[tuple[float, float]] = []
        starts: list[float] = []
        for p in plans:
            starts.append(shapely.LineString(pts).length if len(pts) >= 2 else 0.0)
            for c in p.coords:
                if not pts or math.dist(pts[-1], c) > 1e-6:
                    pts.append((float(c[0]), float(c[1])))
        line = shapely.LineString(pts)
        width = max(p.width for p in plans)
        sp = f"s{k + 1}"
        step_first = len(out)
        straights = [p for p in plans if p.mode not in _INTERSECTIONS]
        first_speed = slow if plans[0].mode in _INTERSECTIONS else cruise
        if speed_now != first_speed:
            out.append(trigger(f"{sp}.speed", "set_speed", gate(line, FIRST_GATE_M, width), SetSpeed(speed=first_speed),
                               f"step {k + 1}: set speed {first_speed:g} m/s"))
        if plans[0].mode not in _INTERSECTIONS:  # an intersection's macro switches detection on after it
            out.append(trigger(f"{sp}.start_obstacles", "start_obstacles", gate(line, FIRST_GATE_M, width), ObstacleDetection(on=True),
                               f"step {k + 1}: start fast obstacle detection"))
        if straights:
            marks = _landmarks(m, straights[0].coords)
            if marks:
                out.append(trigger(f"{sp}.start_landmarks", "start_landmarks", gate(line, FIRST_GATE_M, width),
                                   LandmarkMatching(on=True, landmarks=marks), f"step {k + 1}: start landmark matching"))
        speed_now = first_speed
        for i, p in enumerate(plans):
            inter = p.mode in _INTERSECTIONS
            speed = slow if inter else cruise
            routes.append(Annotation(
                id=f"route.{seg_index:03d}", type="route", destination="road_following",
                text=f"step {k + 1} segment {i + 1}: {p.mode} at {speed:g} m/s", location=Location.line(p.coords),
                data=encode_trigger_data(RouteSegment(index=seg_index, step_index=k, mode=p.mode, points=tuple(p.coords), width=p.width,
                                                      speed=speed, node_id=p.node_id, edge_ids=p.edge_ids))))
            if inter:
                nxt = next((q for q in plans[i + 1:] if q.mode not in _INTERSECTIONS), None)
                out.extend(turn_at_intersection(f"{sp}.x{i + 1}.{p.node_id}", line, starts[i], p.coords, p.node_id or "",
                                                p.width, speed_now, cruise, slow,
                                                _landmarks(m, nxt.coords) if nxt is not None else (), seg_index,
                                                vision=intersections == "vision"))
                speed_now = cruise
            seg_index += 1
        out[step_first:] = _stairs_without_obstacle_stop(sp, line, plans, starts, width, out[step_first:])
        goal = route.goal_xy
        obj, obj_xy = destination_object(m, step.destination.place, goal)
        at = destination_point(goal, obj_xy, list(line.coords))  # beside the object, if any
        # a step kept to a side stops in its goal's lane: the kept side of the road the route arrives on
        stop_xy = lane_goal(route, at, step.constraints.keep) or at
        # on a route shorter than the lead, where the step's first gates are: a gate at the route's very start lies
        # on the corner the vehicle turns from the previous step, which it may never cross (the campus tour's slope)
        out.append(trigger(f"{sp}.stop", "stop_at_object", gate(line, max(min(FIRST_GATE_M, line.length / 2),
                                                                           line.length - STOP_LEAD_M), width),
                           StopAtObject(object_id=obj, x=stop_xy[0], y=stop_xy[1], object_xy=obj_xy, tolerance=step.tolerance,
                                        action=step.trigger.action, wait_s=step.trigger.wait_s),
                           f"step {k + 1}: {step.trigger.action} at {obj}"))
        here = goal
    chained = [r.model_copy(update={"previous_id": routes[j - 1].id if j else None,
                                    "next_id": routes[j + 1].id if j + 1 < len(routes) else None})
               for j, r in enumerate(routes)]
    return CompiledMission(mission=mission.name, map_name=m.name, vehicle=veh, annotations=tuple(chained + out))


def _stairs_without_obstacle_stop(sp: str, line: shapely.LineString, plans, starts: list[float], width: float,
                                  step: list[Annotation]) -> list[Annotation]:
    """Return a step's triggers `step` with fast obstacle detection off from `STAIRS_OBSTACLE_LEAD_M` [m] before each
    climb-stairs segment to its top: a stop gate there, a start gate at the top, and any start gate of the step in
    between left out (an intersection just before the stairs would switch detection on again at its exit)."""
    out = list(step)
    for i, p in enumerate(plans):
        if p.mode != "climb-stairs":
            continue
        s_entry = starts[i]
        s_exit = s_entry + shapely.LineString(p.coords).length
        s_off = min(max(s_entry - STAIRS_OBSTACLE_LEAD_M, FIRST_GATE_M + 0.5), s_entry)
        out = [a for a in out if not (a.type == "start_obstacles" and s_off <= _gate_s(line, a) <= s_exit)]
        out.append(trigger(f"{sp}.stairs{i + 1}.stop_obstacles", "stop_obstacles", gate(line, s_off, width), ObstacleDetection(on=False),
                           "stop fast obstacle detection before the stairs (their risers are no obstacle)"))
        out.append(trigger(f"{sp}.stairs{i + 1}.start_obstacles", "start_obstacles", gate(line, s_exit, width), ObstacleDetection(on=True),
                           "restart fast obstacle detection at the top of the stairs"))
    return out


def _gate_s(line: shapely.LineString, a: Annotation) -> float:
    """Return the arc length [m] along `line` of gate annotation `a`'s middle."""
    pts = a.location.points
    return float(line.project(shapely.Point(sum(x for x, _ in pts) / len(pts), sum(y for _, y in pts) / len(pts))))


def compile_mission_files(mission_path: str | Path, map_path: str | Path, *, vehicle: str | None = None,
                          intersections: str = "dead_reckon") -> CompiledMission:
    """Load the mission YAML and the map file, compile; raise MissionCompileError naming the file."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from modules.map_navigator.mapdata import load_map

    try:
        mission = load_mission(mission_path)
    except FileNotFoundError:
        raise MissionCompileError(f"{mission_path}: no such mission file") from None
    except MissionFileError as exc:
        raise MissionCompileError(str(exc)) from None
    try:
        m = load_map(map_path)
    except FileNotFoundError:
        raise MissionCompileError(f"{map_path}: no such map file") from None
    except WorldFileError as exc:
        raise MissionCompileError(str(exc)) from None
    return compile_mission(mission, m, vehicle=vehicle, intersections=intersections)
