"""What a run is before anything starts: the configuration of `sidewalk run`, the prepared setup, the launch error.

`RunConfig` is what the command line asks for; `RunSetup` what the launcher worked out from it (world,
mission, the map the robot gets, start poses). Both architectures' plans (`sidewalk.architecture`)
read them; `road_method_flags` gives a road-finding module of either the run's road method.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field

from modules.vocabulary import Mission
from sidewalk.compare.faults import FaultSpec
from sidewalk.errors import SidewalkError
from sidewalk.map_error import MapErrorSummary
from sidewalk.supervisor import RestartPolicy
from vehicle_sim.worldfile import World

__all__ = ["LaunchError", "RunConfig", "RunSetup", "road_method_flags", "vision_flags"]


class LaunchError(SidewalkError, RuntimeError):
    """The run could not be set up (bad world, mission, flag) or a process would not start."""


class RunConfig(BaseModel):
    """What `sidewalk run` runs; every run is reproducible from `seed`."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    world: str = "campus"
    mission: str = "campus-tour"
    vehicle: Optional[str] = None  # default: the mission's vehicle, else terregator
    rtf: float = Field(default=20.0, gt=0.0)
    seed: int = 0
    out: Path = Path("runs/latest")
    perception: bool = True
    pose_error_m: float = Field(default=0.0, ge=0.0)
    pose_error_deg: float = 0.0
    map_error_m: Optional[float] = Field(default=None, ge=0.0)
    max_sim_time_s: float = Field(default=3600.0, gt=0.0)
    max_wall_time_s: float = Field(default=1800.0, gt=0.0)
    namespace: Optional[str] = None
    watchdog_s: float = Field(default=1.0, gt=0.0)
    #: how long [s] wall the MAP NAVIGATOR waits for a PILOT that went away before it fails the segment
    pilot_grace_s: float = Field(default=15.0, gt=0.0)
    # ---- monitor and recording (issue 11) ----
    record: bool = True  # write run.mcap beside report.json
    monitor_port: Optional[int] = Field(default=None, ge=1, le=65535)  # serve the monitor page on this port
    # ---- end monitor and recording ----
    secure: Optional[Path] = None  # `sidewalk security init` directory: TLS, passwords, access control (issue 14)
    # ---- laser (issue 12) ----
    actors: Optional[str] = None  # objects not on the map: an actors file or preset (vehicle_sim.actors)
    obstacles: Optional[bool] = None  # run the OBSTACLE DETECTOR (default: when there are actors)
    map_file: Optional[Path] = None  # the map the robot gets (e.g. from `sidewalk mapbuild`); default: the shipped one
    # ---- end laser ----
    #: which architecture runs the mission: the CODGER blackboard system or EDDIE (no blackboard)
    arch: Literal["codger", "eddie"] = "codger"
    # ---- issue 10: faults injected at a sim time after submission, and a speed cap for the PILOT ----
    faults: tuple[FaultSpec, ...] = ()
    max_speed: Optional[float] = Field(default=None, gt=0.0)
    # ---- issue 13: the road method of PERCEPTION (CODGER) and of vision road following (EDDIE) ----
    road_method: Literal["perception", "scarf", "yarf", "alvinn"] = "perception"
    alvinn_weights: Optional[Path] = None  # ALVINN's weights (.npz), needed with road_method alvinn
    # ---- end issue 13 ----
    #: issue 41: the obstacle sensor: the ERIM laser, or FIDO's stereo (CODGER's detector, EDDIE's obstacle stop)
    obstacle_sensor: Literal["laser", "fido"] = "laser"
    #: issue 41: processes the vision of PERCEPTION (CODGER) or vision road following (EDDIE) runs on (1: its own)
    vision_workers: int = Field(default=1, ge=1, le=64)
    #: issue 14: how the supervisor keeps the modules running (crashed: restarted with back-off; wedged: reported, restarted)
    supervise: RestartPolicy = RestartPolicy()
    #: lock-step (`wire.lockstep`): the simulator steps only once every process handled its inputs; `rtf` is then unused
    lockstep: bool = False

    @property
    def time_mode(self) -> Literal["lockstep", "realtime"]:
        """Return how sim time advanced: `lockstep` or `realtime` (at `rtf`)."""
        return "lockstep" if self.lockstep else "realtime"


class RunSetup(BaseModel):
    """What a run needs before anything starts: world (truth), mission, the map file the robot gets, start poses.

    `start_truth` is where the simulator puts the vehicle (the mission's `start`; None: the world's
    start); `start_belief` is the PILOT's start: the mission's start or else the map's, moved by the
    injected pose error (x, y [m], yaw [rad] in `world`). `map_error` is the map measured against the world.
    """

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    world: World
    mission: Mission
    mission_file: Path
    vehicle: str
    map_file: Path
    map_error: MapErrorSummary
    start_truth: Optional[tuple[float, float, float]] = None
    start_belief: tuple[float, float, float]
    destinations: tuple[Optional[tuple[float, float]], ...]
    lane_offsets: tuple[float, ...] = ()
    #: each step's point the truth verdict judges (`sidewalk.lane_goal`; None: a destination the world lacks)
    goal_points: tuple[Optional[tuple[float, float]], ...] = ()


def road_method_flags(cfg: RunConfig, setup: "RunSetup | None" = None) -> tuple[str, ...]:
    """Return the flags that give a road-finding module the run's road method (issue 13; none for the default).

    With `setup` (EDDIE's road following) also the side of the road the mission keeps to: EDDIE's
    route is the road's centre line, and road following drives in the lane (every method).
    """
    keep = ()
    first = setup.mission.steps[0].constraints.keep if setup is not None and setup.mission.steps else None
    if first in ("right", "left"):
        keep = ("--keep", first)
    if cfg.road_method == "perception":
        return keep
    weights = () if cfg.alvinn_weights is None else ("--alvinn-weights", str(Path(cfg.alvinn_weights).resolve()))
    return ("--road-method", cfg.road_method, *weights, *keep)


def vision_flags(cfg: RunConfig) -> tuple[str, ...]:
    """Return the flag that gives a vision module the run's worker count (issue 41; none for the default, one process)."""
    return () if cfg.vision_workers == 1 else ("--vision-workers", str(cfg.vision_workers))
