"""The CAPTAIN: missions (YAML/JSON, files or submitted over Zenoh) sequenced one step at a time."""

from modules.captain.client import CaptainUnavailableError, MissionClient, MissionRejected
from modules.captain.main import build_parser, captain_main, main
from modules.captain.missionfile import CONSTRAINT_NAMES, MissionFileError, MissionProblem, load_mission, parse_mission
from modules.captain.sequencer import MissionRun, Next, SequenceError
from modules.captain.service import Captain, CaptainOptions, new_mission_id
from modules.captain.wire import CancelRequest, ProblemWire, Rejection, SubmitAccepted, WireError

__all__ = [
    "CaptainUnavailableError", "MissionClient", "MissionRejected",
    "build_parser", "captain_main", "main",
    "CONSTRAINT_NAMES", "MissionFileError", "MissionProblem", "load_mission", "parse_mission",
    "MissionRun", "Next", "SequenceError",
    "Captain", "CaptainOptions", "new_mission_id",
    "CancelRequest", "ProblemWire", "Rejection", "SubmitAccepted", "WireError",
]
