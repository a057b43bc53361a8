"""The Sidewalk vocabulary: token types the modules exchange, registered with the blackboard.

Importing this package declares every type (in `wire.token_types`) without loading `blackboard` (EDDIE
imports it too); the blackboard's default registry follows the declarations in any import order
(`sidewalk blackboard serve --types modules.vocabulary`).
One file per token group: mapdata (map objects), mission (CAPTAIN ↔ MAP NAVIGATOR), route
(MAP NAVIGATOR ↔ PILOT), perception (PERCEPTION results), driving (PILOT ↔ PERCEPTION/HELM),
health (heartbeats).

Who writes what (type name: writer → readers; all coordinates in attrs are world frame unless a
`frame` field says otherwise):

- mission, mission_status: CAPTAIN → monitors (status updated in place, one token per mission)
- mission_step: CAPTAIN → MAP NAVIGATOR (state "cancelled" withdraws it)
- step_result: MAP NAVIGATOR → CAPTAIN
- route_plan: MAP NAVIGATOR → monitors (never the PILOT: it sees one segment at a time)
- route_segment: MAP NAVIGATOR → PILOT (one active at a time; state "cancelled" withdraws it)
- segment_result: PILOT → MAP NAVIGATOR (end_xy: where the PILOT thinks the vehicle is)
- driving_unit: PILOT → PERCEPTION, which updates only its status (pending → perceived/failed)
- perception_result: PERCEPTION → PILOT (posted once per driving unit, its own token)
- position_estimate, local_path_constraints: PILOT → monitors
- local_path_plan: PILOT → HELM (newest `seq` wins)
- map_object: MAP NAVIGATOR (copies of the map; also embedded in segments and driving units)
- obstacle_report: OBSTACLE DETECTOR → HELM (newest wins; frame local)
- landmark_fix: OBSTACLE DETECTOR → PILOT (a vehicle position from laser landmarks matched to the map; world)
- terrain_tile: terrain module → PILOT, monitors (a block of the elevation map from the laser; newest per block wins; world)
- heartbeat: every module, on `sidewalk/<ns>/heartbeat/<module>` (not a blackboard token)
"""

from modules.vocabulary._base import XY, Cov3, Frozen, Polyline2, Pose, Ring, register_token_types
from modules.vocabulary.driving import (
    DrivingUnitDescription, LocalPathConstraints, LocalPathPlan, PlanPose, PositionEstimate, UnitStatus,
)
from modules.vocabulary.health import Heartbeat, ModuleState
from modules.vocabulary.obstacle import ObstaclePolygon, ObstacleReport
from modules.vocabulary.landmark import Cov2, LandmarkFix
from modules.vocabulary.mapdata import (
    ColourType, FlatShape, MapColour, MapObject, MapPlaces, ObjectRole, PostShape, PrismShape, Shape, SlopeShape, StairsShape,
    TreeShape,
)
from modules.vocabulary.mission import (
    DEFAULT_TOLERANCE_M, TERMINAL_STATES, Destination, KeepSide, Mission, MissionStart, MissionState, MissionStatus,
    MissionStep, MissionStepSpec, StepConstraints, StepOutcome, StepProgress, StepResult, Trigger, TriggerAction, Waiting,
)
from modules.vocabulary.perception import (
    DetectedObject, LineFix, PerceptionResult, PointFix, PositionFix, ResultFrame, SensorMode, SurfaceType,
)
from modules.vocabulary.terrain import TerrainTile
from modules.vocabulary.route import (
    NAVIGATION_MODES, DrivingConstraints, ExitCondition, NavigationMode, RoutePlan, RouteSegmentDescription,
    SegmentResult,
)

#: Registered token type name of each vocabulary model.
TOKEN_TYPES: dict[type, str] = {
    MapObject: "map_object",
    MapPlaces: "map_places",
    Mission: "mission",
    MissionStep: "mission_step",
    StepResult: "step_result",
    MissionStatus: "mission_status",
    RoutePlan: "route_plan",
    RouteSegmentDescription: "route_segment",
    SegmentResult: "segment_result",
    DrivingUnitDescription: "driving_unit",
    PerceptionResult: "perception_result",
    PositionEstimate: "position_estimate",
    LocalPathConstraints: "local_path_constraints",
    LocalPathPlan: "local_path_plan",
    Heartbeat: "heartbeat",
    ObstacleReport: "obstacle_report",
    LandmarkFix: "landmark_fix",
    TerrainTile: "terrain_tile",
}

__all__ = [
    "XY", "Cov3", "Frozen", "Polyline2", "Pose", "Ring",
    "DrivingUnitDescription", "LocalPathConstraints", "LocalPathPlan", "PlanPose", "PositionEstimate", "UnitStatus",
    "Heartbeat", "ModuleState",
    "ObstaclePolygon", "ObstacleReport", "Cov2", "LandmarkFix",
    "ColourType", "MapColour", "FlatShape", "MapObject", "MapPlaces", "ObjectRole", "PostShape", "PrismShape", "Shape", "SlopeShape",
    "StairsShape", "TreeShape",
    "DEFAULT_TOLERANCE_M", "TERMINAL_STATES", "Destination", "KeepSide", "Mission", "MissionStart", "MissionState",
    "MissionStatus", "MissionStep", "MissionStepSpec", "StepConstraints", "StepOutcome", "StepProgress", "StepResult", "Trigger",
    "TriggerAction", "Waiting",
    "DetectedObject", "LineFix", "PerceptionResult", "PointFix", "PositionFix", "ResultFrame", "SensorMode",
    "SurfaceType",
    "NAVIGATION_MODES", "DrivingConstraints", "ExitCondition", "NavigationMode", "RoutePlan",
    "RouteSegmentDescription", "SegmentResult",
    "TerrainTile",
    "TOKEN_TYPES", "register_token_types",
]
