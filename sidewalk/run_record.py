"""A recorded run: everything its report is built from, and nothing of the architecture that ran it.

The launcher fills a `RunRecord` while the run goes (truth, estimates, events, mission statuses,
route plans, heartbeats) and writes it next to the report as `run_record.json`; `build_report`
turns it into the report without any running part. Tracks are rows (stamp [s] sim, x [m], y [m],
yaw [rad]) in `world`. Wall stamps [s] count from the moment the launcher started the run.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path
from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, ValidationError

from modules.vocabulary import Mission, MissionStatus
from sidewalk.errors import SidewalkError
from sidewalk.map_error import MapErrorSummary
from wire.drive import SimEvent
from wire.health import ProcessUsage
from sidewalk.supervisor import GiveUp, Restart, WedgeReport

__all__ = ["RunRecord", "StampedStatus", "RecordedPlan", "ProcessCost", "FiredTrigger", "FaultEvent", "Architecture", "RunRecordError",
           "save_record", "load_record"]

#: The architectures a run can be recorded under.
Architecture = Literal["codger", "eddie"]

_FROZEN = ConfigDict(frozen=True, extra="forbid")


class RunRecordError(SidewalkError, ValueError):
    """A run record file that cannot be read; names the file and what is wrong."""


class StampedStatus(BaseModel):
    """A mission status as the launcher received it: wall [s] since the run started, sim [s] clock then."""

    model_config = _FROZEN

    wall_s: float
    sim_s: Optional[float] = None
    status: MissionStatus


class RecordedPlan(BaseModel):
    """One route plan of a step (`revision` 0 = first plan): its polyline (N,2) [m] in `world`, posted at `stamp` [s] sim."""

    model_config = _FROZEN

    step_index: int
    revision: int
    stamp: float
    polyline: tuple[tuple[float, float], ...]


class ProcessCost(BaseModel):
    """The last heartbeat's usage of one process incarnation (`name`, `pid`)."""

    model_config = _FROZEN

    name: str
    pid: int
    usage: ProcessUsage


class FiredTrigger(BaseModel):
    """One trigger the EDDIE annotated map manager fired: at `sim_s` [s] sim, where the robot believed it was (x, y [m] `world`).

    `annotation` names the trigger annotation, `kind` its trigger type, `destination` the module it was sent to.
    """

    model_config = _FROZEN

    sim_s: float
    x: float
    y: float
    annotation: str
    kind: str
    destination: str
    text: str = ""


class FaultEvent(BaseModel):
    """A fault injected into the run (`sidewalk run --fault`): what, into which process, when [s] sim.

    `restored_sim_s` is when the injector undid it (the process was ready again, or continued);
    None: nothing to undo. `injected` False: the run had no part to inject it into (`detail` says why).
    """

    model_config = _FROZEN

    name: str
    target: str = ""
    injected: bool
    at_sim_s: float
    restored_sim_s: Optional[float] = None
    detail: str = ""


class RunRecord(BaseModel):
    """Everything measured during one run, for `build_report`.

    `destinations` are the steps' true destinations (x, y) [m] in `world`, resolved from the world
    file (None: a place the world lacks); `goal_points` are where the verdict judges each step: its
    destination moved into the lane it keeps to (`lane_offsets`), on the route's direction of travel on
    the world's path graph (`sidewalk.lane_goal`). `submitted_*` is when the CAPTAIN accepted the mission and
    `ended_*` when the launcher saw it end (or gave up); `*_wall_s` [s] since the run started, `*_sim_s`
    the sim clock [s] then; `rest_sim_s` [s] when the vehicle was seen standing still after the end
    (None: not seen); the truth goes on until then. `stop_reason` says why the launcher gave up
    before the mission ended.
    """

    model_config = _FROZEN

    architecture: Architecture
    mission: Mission
    world: str
    #: the world file the run loaded, when it was given as a file rather than a name in worlds/ (None: the name)
    world_file: Optional[str] = None
    vehicle: str
    seed: int
    perception: bool
    pose_error: tuple[float, float] = (0.0, 0.0)
    map_error: Optional[MapErrorSummary] = None
    rtf_requested: float
    #: how sim time advanced: `realtime` (at `rtf_requested`) or `lockstep` (the simulator waited for every module)
    time_mode: Literal["realtime", "lockstep"] = "realtime"
    destinations: tuple[Optional[tuple[float, float]], ...]
    #: per step, the lane the mission asked for: the signed offset [m] from the path centre at the
    #: destination, + left of travel (keep right on a 6 m road: −1.5); empty: every step on the centre
    lane_offsets: tuple[float, ...] = ()
    #: per step, the point judged (x, y) [m] `world` (None: a place the world lacks); empty (records before issue 36):
    #: the destinations themselves
    goal_points: tuple[Optional[tuple[float, float]], ...] = ()
    submitted_wall_s: float
    submitted_sim_s: float
    ended_wall_s: float
    ended_sim_s: float
    rest_sim_s: Optional[float] = None
    stop_reason: str = ""
    truth: tuple[tuple[float, float, float, float], ...] = ()
    estimate: tuple[tuple[float, float, float, float], ...] = ()
    events: tuple[SimEvent, ...] = ()
    statuses: tuple[StampedStatus, ...] = ()
    plans: tuple[RecordedPlan, ...] = ()
    processes: tuple[ProcessCost, ...] = ()
    blackboard: Optional[dict[str, int | float]] = None
    exit_codes: dict[str, Optional[int]] = {}
    actors: Optional[str] = None  # issue 12: objects not on the map (file or preset) the run had
    #: EDDIE: every trigger fired during the run, in order (CODGER: none)
    triggers: tuple[FiredTrigger, ...] = ()
    #: faults injected by `--fault` (issue 10), and the speed cap given by `--max-speed` [m/s] (None: the vehicle's)
    faults: tuple[FaultEvent, ...] = ()
    max_speed: Optional[float] = None
    #: what the supervisor did (issue 14): processes restarted, wedges reported, processes given up on;
    #: `at_s` [s] wall since the system started
    restarts: tuple[Restart, ...] = ()
    wedges: tuple[WedgeReport, ...] = ()
    gave_up: tuple[GiveUp, ...] = ()


def save_record(record: RunRecord, path: Path) -> Path:
    """Write the record as JSON (gzip-compressed when `path` ends in .gz) and return the path."""
    text = record.model_dump_json()
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".gz":
        path.write_bytes(gzip.compress(text.encode(), mtime=0))
    else:
        path.write_text(text + "\n")
    return path


def load_record(path: Path) -> RunRecord:
    """Read a record written by `save_record`; raise RunRecordError naming the file and the problem."""
    try:
        raw = path.read_bytes()
        text = gzip.decompress(raw).decode() if path.suffix == ".gz" else raw.decode()
        return RunRecord.model_validate(json.loads(text))
    except (OSError, UnicodeDecodeError, gzip.BadGzipFile, EOFError) as exc:
        raise RunRecordError(f"{path}: cannot read the run record: {exc}") from None
    except json.JSONDecodeError as exc:
        raise RunRecordError(f"{path}: not JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}") from None
    except ValidationError as exc:
        e = exc.errors()[0]
        raise RunRecordError(f"{path}: not a run record: {'.'.join(map(str, e['loc']))}: {e['msg']}") from None
