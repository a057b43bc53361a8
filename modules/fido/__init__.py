"""FIDO, the Terregator's stereo navigation vision (Navlab 1990 §4.3), as a plain library: no transport, no truth.

The seven-level pyramid of 2×2 averages, Moravec's interest operator, coarse-to-fine pyramid
correlation with the paper's pseudo-normalised correlation, triangulation in the rectified pair,
features tracked from step to step (found again in each new right image, then in the left), the
vehicle's motion from the tracked features, and obstacle features. The image cores (pyramid,
interest operator) run on overlapping stripes and the correlation on any split of the feature
list, with the same results as on the whole, so a parallel facility can spread them over workers.
"""

from modules.fido.correlation import SEARCH, TEMPLATE, Matches, pseudo_normalised_correlation, pyramid_correlate
from modules.fido.errors import FidoError, MotionError, StereoGeometryError
from modules.fido.fido import FeatureTable, FidoConfig, FidoMemory, FidoStep, StepTiming, fido_step
from modules.fido.interest import INTEREST_HALO, InterestPoints, interest_map, select_features
from modules.fido.motion import CHI2_3DOF_99, Motion, PlanarMotion, estimate_motion
from modules.fido.obstacle_features import obstacle_mask
from modules.fido.obstacle_watch import FidoObstacleWatch, FidoSighting, FidoWatchConfig, corridor_distance, motion_between
from modules.fido.pyramid import PYRAMID_LEVELS, build_pyramid, from_level, reduce, stripe_alignment, to_level
from modules.fido.stereo_pair import StereoPair, StereoRig, grey
from modules.fido.triangulation import StereoPoints, triangulate

__all__ = [
    "SEARCH", "TEMPLATE", "Matches", "pseudo_normalised_correlation", "pyramid_correlate",
    "FidoError", "MotionError", "StereoGeometryError",
    "FeatureTable", "FidoConfig", "FidoMemory", "FidoStep", "StepTiming", "fido_step",
    "INTEREST_HALO", "InterestPoints", "interest_map", "select_features",
    "CHI2_3DOF_99", "Motion", "PlanarMotion", "estimate_motion",
    "obstacle_mask",
    "FidoObstacleWatch", "FidoSighting", "FidoWatchConfig", "corridor_distance", "motion_between",
    "PYRAMID_LEVELS", "build_pyramid", "from_level", "reduce", "stripe_alignment", "to_level",
    "StereoPair", "StereoRig", "grey",
    "StereoPoints", "triangulate",
]
