"""Road following as the Navlab did it (Navlab 1990 §2.2): SCARF, YARF and ALVINN, plain libraries.

Each follower takes camera frames (H, W, 3) uint8 with the camera model of the capture
(`CameraGeometry.from_capture`) and reports a `RoadObservation` per frame: the road in `vehicle`
(SCARF, YARF) or a steering arc and its road point (ALVINN), a confidence and the time taken.
"""

from modules.road_following.alvinn import Alvinn
from modules.road_following.alvinn_net import AlvinnNet, AlvinnShape, decode_steering, steering_targets
from modules.road_following.alvinn_training import arc_road_point, moved_line, pursuit_curvature, retina, shifted_view, training_views
from modules.road_following.camera import CameraGeometry
from modules.road_following.colour_classes import ColourClass, ColourClasses, classify, estimate_classes
from modules.road_following.errors import AlvinnModelError, CameraGeometryError, RoadFollowingError
from modules.road_following.follower import Branch, FeatureReport, RoadFollower, RoadObservation, VehicleMotion
from modules.road_following.intersection import find_branches
from modules.road_following.road_method import FOLLOWER_METHODS, ROAD_METHODS, CameraRoadFollower, RoadMethod, load_alvinn_weights
from modules.road_following.road_seen import NoRoadSeen, cross_section, drive_line, motion_between, road_region, steering_arc
from modules.road_following.scarf import Scarf, ScarfConfig
from modules.road_following.spine_fit import Spine, SpineFit, fit_spine_lsq, fit_spine_robust
from modules.road_following.triangle_road import TriangleRoad, best_triangle, half_width_rate, triangle_in_vehicle, triangle_mask, vote
from modules.road_following.yarf import LaneModel, StripeFeature, Yarf, YarfConfig
from modules.road_following.yarf_trackers import track_white, track_yellow, yellow_mask

__all__ = [
    "Alvinn", "AlvinnNet", "AlvinnShape", "decode_steering", "steering_targets",
    "arc_road_point", "moved_line", "pursuit_curvature", "retina", "shifted_view", "training_views",
    "CameraGeometry", "ColourClass", "ColourClasses", "classify", "estimate_classes",
    "AlvinnModelError", "CameraGeometryError", "RoadFollowingError",
    "Branch", "FeatureReport", "RoadFollower", "RoadObservation", "VehicleMotion",
    "find_branches", "Scarf", "ScarfConfig", "Spine", "SpineFit", "fit_spine_lsq", "fit_spine_robust",
    "TriangleRoad", "best_triangle", "half_width_rate", "triangle_in_vehicle", "triangle_mask", "vote",
    "FOLLOWER_METHODS", "ROAD_METHODS", "CameraRoadFollower", "RoadMethod", "load_alvinn_weights",
    "NoRoadSeen", "cross_section", "drive_line", "motion_between", "road_region", "steering_arc",
    "LaneModel", "StripeFeature", "Yarf", "YarfConfig", "track_white", "track_yellow", "yellow_mask",
]
