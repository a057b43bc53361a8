"""Macro packages of triggers (the seed's planned higher-level interface): one call, several trigger annotations.

`turn_at_intersection` expands, around one intersection segment of the route, into: slow down to the
intersection speed before it, stop landmark matching and fast obstacle detection (the scene in an
intersection confuses both), dead-reckon through along the segment's centreline; after it, resume
vision, restart obstacle detection and landmark matching, and set the cruise speed again.
Triggers are `cross` gates: short lines across the route, so a vehicle off the centreline crosses them too.
"""

from __future__ import annotations


import numpy as np
import shapely

from eddie.annotated_map.annotation import Annotation, Location
from eddie.messages.map_manager import (DeadReckonThrough, LandmarkMatching, ObstacleDetection, ResumeVision, SetSpeed,
                                        VisionThroughIntersection, encode_trigger_data)
from eddie.toolkit.message import Message

__all__ = ["gate", "trigger", "turn_at_intersection", "point_along", "BRAKE_DECEL_M_S2"]

#: Deceleration [m/s²] used to place a slow-down gate so the vehicle is slow at the segment boundary.
BRAKE_DECEL_M_S2 = 1.0

#: Destination module of each trigger type: the module names of the EDDIE system configuration
#: (eddie.messages.map_manager's table). Dead reckoning goes to the vision module because it holds
#: world←local and hands the controller the path in `local`.
DESTINATIONS = {
    "set_speed": "controller", "dead_reckon_intersection": "road_following", "resume_vision": "road_following",
    "start_landmarks": "landmark_matching", "stop_landmarks": "landmark_matching", "stop_at_object": "obstacle_stop",
    "stop_obstacles": "obstacle_stop", "start_obstacles": "obstacle_stop", "vision_through_intersection": "road_following",
    "switch_perception": "road_following",
}


def point_along(line: shapely.LineString, s: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """Return the point [m `world`] at arc length `s` [m] on `line` (clamped) and the unit direction of travel there."""
    s = min(max(s, 0.0), line.length)
    p = line.interpolate(s)
    a = line.interpolate(max(s - 0.5, 0.0))
    b = line.interpolate(min(s + 0.5, line.length))
    d = np.array([b.x - a.x, b.y - a.y])
    n = float(np.linalg.norm(d))
    u = (1.0, 0.0) if n < 1e-9 else (float(d[0] / n), float(d[1] / n))
    return (p.x, p.y), u


def gate(line: shapely.LineString, s: float, width: float) -> Location:
    """Return a gate: a line [m `world`] across `line` at arc length `s` [m], `width` + 2 m long."""
    (x, y), (ux, uy) = point_along(line, s)
    h = width / 2.0 + 1.0
    return Location.line([(x - uy * h, y + ux * h), (x + uy * h, y - ux * h)])


def trigger(aid: str, type_: str, loc: Location, data: Message, text: str) -> Annotation:
    """Return a `cross` trigger annotation of `type_` to its table destination, `data` enveloped."""
    return Annotation(id=aid, type=type_, destination=DESTINATIONS[type_], text=text, location=loc, trigger="cross",
                      data=encode_trigger_data(data))


def turn_at_intersection(prefix: str, before: shapely.LineString, s_entry: float, seg_coords, node_id: str,
                         width: float, from_speed: float, cruise_speed: float, slow_speed: float,
                         landmarks: tuple[str, ...], segment_index: int, *, vision: bool = False) -> list[Annotation]:
    """Expand the "turn at intersection" macro for the intersection segment `seg_coords` [m `world`].

    With `vision` the road follower keeps vision on through it (`vision_through_intersection`)
    instead of the controller dead-reckoning and vision resuming after it.

    `before` is the whole route line, `s_entry` [m] the arc length where the intersection segment begins;
    the slow-down gate sits the braking distance from `from_speed` [m/s] before it.
    """
    seg = shapely.LineString(seg_coords)
    s_exit = s_entry + seg.length
    brake = max(0.0, (from_speed ** 2 - slow_speed ** 2) / (2.0 * BRAKE_DECEL_M_S2))
    s_slow = max(0.0, s_entry - brake)
    out = [
        trigger(f"{prefix}.slow", "set_speed", gate(before, s_slow, width), SetSpeed(speed=slow_speed),
                f"slow to {slow_speed:g} m/s before intersection {node_id}"),
        trigger(f"{prefix}.stop_landmarks", "stop_landmarks", gate(before, s_entry, width), LandmarkMatching(on=False),
                f"stop landmark matching in intersection {node_id}"),
        trigger(f"{prefix}.stop_obstacles", "stop_obstacles", gate(before, s_entry, width), ObstacleDetection(on=False),
                f"stop fast obstacle detection in intersection {node_id}"),
        *([trigger(f"{prefix}.vision_through", "vision_through_intersection", gate(before, s_entry, width),
                   VisionThroughIntersection(node_id=node_id), f"vision through intersection {node_id}")] if vision else [
            trigger(f"{prefix}.dead_reckon", "dead_reckon_intersection", gate(before, s_entry, width),
                    DeadReckonThrough(node_id=node_id, points=tuple(seg_coords), speed=slow_speed),
                    f"dead-reckon through intersection {node_id}"),
            trigger(f"{prefix}.resume_vision", "resume_vision", gate(before, s_exit, width),
                    ResumeVision(node_id=node_id, segment_index=segment_index + 1),
                    f"resume vision after intersection {node_id}")]),
        trigger(f"{prefix}.start_obstacles", "start_obstacles", gate(before, s_exit, width), ObstacleDetection(on=True),
                f"restart fast obstacle detection after intersection {node_id}"),
        trigger(f"{prefix}.cruise", "set_speed", gate(before, s_exit, width), SetSpeed(speed=cruise_speed),
                f"back to {cruise_speed:g} m/s after intersection {node_id}"),
    ]
    if landmarks:
        out.append(trigger(f"{prefix}.start_landmarks", "start_landmarks", gate(before, s_exit, width),
                           LandmarkMatching(on=True, landmarks=landmarks),
                           f"start landmark matching after intersection {node_id}"))
    return out


