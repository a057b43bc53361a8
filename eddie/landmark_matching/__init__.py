"""Landmark matching (EDDIE): landmarks seen against the map, fixes to the navigator; `python -m eddie.landmark_matching`."""

from eddie.landmark_matching.landmark_matching import LandmarkFix, landmark_fix
from eddie.landmark_matching.landmark_matching_module import LandmarkMatching

__all__ = ["LandmarkFix", "landmark_fix", "LandmarkMatching"]
