"""The HELM (seed: Sidewalk §2.3.4): tracks the newest local path plan, drives the vehicle, and
keeps the moving vehicle position (local←vehicle) on the blackboard.

Pure core: `tracker` (pure pursuit). The process: `modules.helm.helm.Helm`, run with `python -m modules.helm`.
"""

from modules.helm.tracker import PathTracker, TrackCommand, TrackerConfig, TrackerError, tracker_config_for

__all__ = ["PathTracker", "TrackCommand", "TrackerConfig", "TrackerError", "tracker_config_for"]
