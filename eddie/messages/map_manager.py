"""Messages of the annotated map manager: its query service, the trigger it delivers, and the trigger data.

The manager never interprets an annotation's data. Mission triggers carry, as data, one of the
trigger-data messages below in a full envelope (`encode_trigger_data`); the manager wraps the
bytes in a `TriggerMessage` to the annotation's destination module, which opens them with
`open_trigger_data`. The nine trigger types of the seed (§3.3) and the route:

| type | destination | data |
|---|---|---|
| `set_speed` | controller | `SetSpeed` |
| `dead_reckon_intersection` | road_following (it holds world←local; sends the controller a `DeadReckon` in `local`) | `DeadReckonThrough` |
| `resume_vision` | road_following | `ResumeVision` |
| `start_landmarks` / `stop_landmarks` | landmark_matching | `LandmarkMatching` |
| `stop_at_object` | obstacle_stop | `StopAtObject` |
| `stop_obstacles` / `start_obstacles` | obstacle_stop | `ObstacleDetection` |
| `vision_through_intersection` | road_following | `VisionThroughIntersection` |
| `switch_perception` | road_following | `SwitchPerception` |
| `route` (not a trigger; queried) | road_following | `RouteSegment` |
"""

from __future__ import annotations

import base64
import math
from typing import Annotated, Literal

from pydantic import AfterValidator, Field

from eddie.toolkit.message import Message, decode_envelope, encode_envelope, message_type

__all__ = [
    "AnnotationQuery", "AnnotationRecord", "AnnotationList", "MissionAnnotations", "MissionInstalled", "TriggerMessage",
    "TriggerFired",
    "SetSpeed", "DeadReckonThrough", "ResumeVision", "LandmarkMatching", "StopAtObject", "ObstacleDetection",
    "VisionThroughIntersection", "SwitchPerception", "RouteSegment", "TRIGGER_TYPES",
    "encode_trigger_data", "open_trigger_data",
]


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError(f"must be a finite number, got {v!r}")
    return v


_F = Annotated[float, AfterValidator(_finite)]
XY = tuple[_F, _F]

#: The seed's nine trigger types (start / stop pairs counted once each).
TRIGGER_TYPES: tuple[str, ...] = (
    "set_speed", "dead_reckon_intersection", "resume_vision", "start_landmarks", "stop_landmarks",
    "stop_at_object", "stop_obstacles", "start_obstacles", "vision_through_intersection", "switch_perception",
)


# ---- the query service ----------------------------------------------------------------------

@message_type("map_manager.query")
class AnnotationQuery(Message):
    """Ask for every annotation of `type` (any if None) within `polygon` [(x, y)] [m] `world` (anywhere if None)."""

    type: str | None = None
    polygon: tuple[XY, ...] | None = Field(None, min_length=3)


class AnnotationRecord(Message):
    """One annotation as answered: the header, the location in `world` [m], the data base64-encoded."""

    id: str
    type: str
    destination: str
    used: bool
    text: str
    kind: Literal["point", "line", "polygon"]
    points: tuple[XY, ...]
    next_id: str | None = None
    previous_id: str | None = None
    trigger: str = "none"
    data_size: int = 0
    data_base64: str = ""


@message_type("map_manager.annotations")
class AnnotationList(Message):
    """The answer to an `AnnotationQuery`: the matching annotations, by id."""

    annotations: tuple[AnnotationRecord, ...] = ()


# ---- the mission service: a submitted mission's annotations ------------------------------------

@message_type("map_manager.mission")
class MissionAnnotations(Message):
    """Install mission `mission_id`'s trigger annotations (`geojson`: a FeatureCollection in `world` [m]) in place of the last mission's."""

    mission_id: str = Field(min_length=1)
    name: str = ""
    geojson: str


@message_type("map_manager.mission_installed")
class MissionInstalled(Message):
    """The answer to `MissionAnnotations`: the mission whose annotations the manager now holds, and how many."""

    mission_id: str
    count: int = Field(ge=0)


# ---- what the manager sends and publishes -------------------------------------------------------

@message_type("map_manager.trigger")
class TriggerMessage(Message):
    """A trigger delivered to its destination: which annotation, where [m `world`] and when it was crossed, its data.

    `stamp` [s sim] and `crossed_wall` [s, time.time()] are of the cycle whose travelled line crossed
    it (the wall time measures trigger latency). `data_base64` is the annotation's opaque data.
    """

    annotation_id: str
    trigger_type: str
    text: str = ""
    x: _F
    y: _F
    stamp: float | None = None
    crossed_wall: float
    data_base64: str = ""

    @property
    def data(self) -> bytes:
        """Return the annotation's data bytes."""
        return base64.b64decode(self.data_base64)


@message_type("map_manager.trigger_fired")
class TriggerFired(Message):
    """One trigger outcome on stream `map_manager/triggers` (the monitor's contract); `event` fired / skipped / rearmed."""

    stamp: float | None
    annotation_id: str
    trigger_type: str
    destination: str
    x: _F
    y: _F
    text: str = ""
    event: Literal["fired", "skipped", "rearmed"] = "fired"
    via: str = "travel"


# ---- trigger data (the seed's trigger types) -------------------------------------------------------

@message_type("map_manager.set_speed")
class SetSpeed(Message):
    """Set the commanded speed limit to `speed` [m/s] from here on."""

    speed: _F = Field(ge=0.0)


@message_type("map_manager.dead_reckon_through")
class DeadReckonThrough(Message):
    """Dead-reckon through intersection `node_id` along `points` [(x, y)] [m] `world` at `speed` [m/s]."""

    node_id: str = ""
    points: tuple[XY, ...] = Field(min_length=2)
    speed: _F = Field(0.5, ge=0.0)


@message_type("map_manager.resume_vision")
class ResumeVision(Message):
    """Resume vision road following after intersection `node_id` (on segment `segment_index`)."""

    node_id: str = ""
    segment_index: int = 0


@message_type("map_manager.landmark_matching")
class LandmarkMatching(Message):
    """Start (`on`) or stop landmark matching; `landmarks` names the map objects to look for."""

    on: bool
    landmarks: tuple[str, ...] = ()


@message_type("map_manager.stop_at_object")
class StopAtObject(Message):
    """Stop at the goal (x, y) [m] `world` of map object `object_id` (the seed: the mailbox), within `tolerance` [m].

    `object_xy` is where the map has the object itself (`world` [m]; None: no such object on the map):
    the laser sees it on the way in, and the stop is judged relative to it.
    """

    object_id: str
    x: _F
    y: _F
    object_xy: tuple[_F, _F] | None = None
    tolerance: _F = Field(1.5, gt=0.0)
    action: Literal["stop", "wait", "continue"] = "stop"
    wait_s: _F = Field(0.0, ge=0.0)


@message_type("map_manager.obstacle_detection")
class ObstacleDetection(Message):
    """Start (`on`) or stop fast obstacle detection (stopped where the scene would confuse it)."""

    on: bool


@message_type("map_manager.vision_through_intersection")
class VisionThroughIntersection(Message):
    """Keep vision on through intersection `node_id` (instead of dead reckoning)."""

    node_id: str = ""


@message_type("map_manager.switch_perception")
class SwitchPerception(Message):
    """Switch the road follower to perception module `module` (e.g. colour, colored_range) from here on."""

    module: str = Field(min_length=1)


@message_type("map_manager.route_segment")
class RouteSegment(Message):
    """One route segment to follow: `index` in driving order, the mission step it belongs to, its navigation `mode`, centreline in `world` [m], `speed` [m/s]."""

    index: int = Field(ge=0)
    step_index: int = Field(0, ge=0)
    mode: str
    points: tuple[XY, ...] = Field(min_length=2)
    width: _F = Field(gt=0.0)
    speed: _F = Field(ge=0.0)
    node_id: str | None = None
    edge_ids: tuple[str, ...] = ()


def encode_trigger_data(msg: Message) -> bytes:
    """Return `msg` as an annotation's data bytes (a msgpack envelope from `annotated_map`)."""
    return encode_envelope("annotated_map", msg, None)


def open_trigger_data(data: bytes | TriggerMessage) -> Message:
    """Return the typed message in an annotation's data (or a `TriggerMessage`'s); raise BadMessage."""
    raw = data.data if isinstance(data, TriggerMessage) else data
    return decode_envelope(raw, where="annotation data")[1]
