"""The CAPTAIN: missions (YAML/JSON, files or submitted over Zenoh) sequenced one step at a time.

The service and its process (`service`, `main`) use the blackboard and load on first use, so EDDIE
can reuse the mission file, the sequencer and the wire forms without loading the blackboard.
"""

import importlib as _importlib

from modules.captain.client import CaptainUnavailableError, MissionClient, MissionRejected
from modules.captain.missionfile import CONSTRAINT_NAMES, MissionFileError, MissionProblem, load_mission, parse_mission
from modules.captain.progress import PROGRESS_M, RouteProgress
from modules.captain.sequencer import MissionRun, Next, SequenceError
from modules.captain.wire import CancelRequest, ProblemWire, Rejection, SubmitAccepted, WireError, new_mission_id

__all__ = [
    "CaptainUnavailableError", "MissionClient", "MissionRejected",
    "build_parser", "captain_main", "main",
    "CONSTRAINT_NAMES", "MissionFileError", "MissionProblem", "load_mission", "parse_mission",
    "MissionRun", "Next", "SequenceError", "PROGRESS_M", "RouteProgress",
    "Captain", "CaptainOptions", "new_mission_id",
    "CancelRequest", "ProblemWire", "Rejection", "SubmitAccepted", "WireError",
]

#: names served lazily: the blackboard-bound parts
_LAZY = {"build_parser": "main", "captain_main": "main", "main": "main",
         "Captain": "service", "CaptainOptions": "service"}


def __getattr__(name: str):
    """Load the blackboard-bound parts on first use."""
    if name in _LAZY:
        sub = _importlib.import_module(f"{__name__}.{_LAZY[name]}")
        # importing the submodule bound its name here (`main`): bind the functions instead
        globals().update({n: getattr(sub, n) for n, m in _LAZY.items() if m == _LAZY[name]})
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
