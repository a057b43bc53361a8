"""The HELM's core (seed: Sidewalk §2.3.4): the path tracker (pure pursuit), used by CODGER's HELM and EDDIE's controller.

The process on the blackboard is `codger.helm` (`python -m codger.helm`).
"""

from modules.helm.tracker import PathTracker, TrackCommand, TrackerConfig, TrackerError, tracker_config_for

__all__ = ["PathTracker", "TrackCommand", "TrackerConfig", "TrackerError", "tracker_config_for"]
