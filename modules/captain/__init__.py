"""The CAPTAIN: missions (YAML/JSON, files or submitted over Zenoh) sequenced one step at a time.

The library parts both architectures use; the CAPTAIN's blackboard service is `codger.captain`.
"""

from modules.captain.client import CaptainUnavailableError, MissionClient, MissionRejected
from modules.captain.missionfile import CONSTRAINT_NAMES, MissionFileError, MissionProblem, load_mission, parse_mission
from modules.captain.sequencer import MissionRun, Next, SequenceError
from modules.captain.wire import CancelRequest, ProblemWire, Rejection, SubmitAccepted, WireError, new_mission_id

__all__ = [
    "CaptainUnavailableError", "MissionClient", "MissionRejected",
    "CONSTRAINT_NAMES", "MissionFileError", "MissionProblem", "load_mission", "parse_mission",
    "MissionRun", "Next", "SequenceError",
    "new_mission_id",
    "CancelRequest", "ProblemWire", "Rejection", "SubmitAccepted", "WireError",
]
