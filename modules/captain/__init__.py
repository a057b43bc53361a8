"""The CAPTAIN: missions (YAML/JSON, files or submitted over Zenoh) sequenced one step at a time.

The library parts both architectures use; the CAPTAIN's blackboard service is `codger.captain`; the
mission contract (submit, status, cancel) is `wire.mission`.
"""

from modules.captain.missionfile import CONSTRAINT_NAMES, MissionFileError, MissionProblem, load_mission, parse_mission, rejection_from
from modules.captain.progress import PROGRESS_M, RouteProgress
from modules.captain.sequencer import MissionRun, Next, SequenceError

__all__ = [
    "CONSTRAINT_NAMES", "MissionFileError", "MissionProblem", "load_mission", "parse_mission", "rejection_from",
    "MissionRun", "Next", "SequenceError", "PROGRESS_M", "RouteProgress",
]
