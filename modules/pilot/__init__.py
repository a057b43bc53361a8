"""The PILOT (seed: Sidewalk §2.3.3): driving monitor, driving unit finder, position estimator,
driving unit navigator and local path planner, pipelined as in the paper's Figure 6.

Pure cores (no network, no blackboard; both architectures use them as libraries): `driving_units`,
`kalman`, `local_path_constraints`, `planner`, `speed_profile`, `segment`, exported here. The PILOT's five
parts on the blackboard and the process that wires them are `codger.pilot` (`python -m codger.pilot`).
"""

from modules.pilot.config import PilotConfig, pilot_config_for
from modules.pilot.errors import PilotError
from modules.pilot.driving_units import DrivingUnitConfig, DrivingUnitSpan, ExpectedObject, split_segment
from modules.pilot.kalman import EstimatorError, LineFix, OdometryNoise, PointFix, PoseFilter
from modules.pilot.local_path_constraints import ConstraintError, LocalConstraints, NavigatorConfig, local_constraints
from modules.pilot.planner import LocalPathPlanner, PlannedPath, PlannerConfig, PlanningError, path_curvature, seed_ompl
from modules.pilot.polyline import PathLine, PolylineError
from modules.pilot.segment import SegmentDriver, SegmentGeometry, map_region
from modules.pilot.speed_profile import SpeedConfig, speed_profile

__all__ = [
    "PilotConfig", "pilot_config_for", "PilotError",
    "DrivingUnitConfig", "DrivingUnitSpan", "ExpectedObject", "split_segment",
    "EstimatorError", "LineFix", "OdometryNoise", "PointFix", "PoseFilter",
    "ConstraintError", "LocalConstraints", "NavigatorConfig", "local_constraints",
    "LocalPathPlanner", "PlannedPath", "PlannerConfig", "PlanningError", "path_curvature", "seed_ompl",
    "PathLine", "PolylineError",
    "SegmentDriver", "SegmentGeometry", "map_region",
    "SpeedConfig", "speed_profile",
]
