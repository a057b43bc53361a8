"""`sidewalk run`: the router, the blackboard node, the simulator and every module as OS processes on loopback.

The launcher starts each process, waits for its ready line, submits the mission to the CAPTAIN over
Zenoh (as `sidewalk submit` does), follows the mission status on the blackboard, records truth and
estimates for the report, and stops everything — also on Ctrl-C.
"""

from __future__ import annotations

import asyncio
import math
import os
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from wire.ports import free_port
from modules.captain.missionfile import MissionFileError, load_mission
from modules.vocabulary import Mission, MissionStatus
from sidewalk.metrics import cross_track_errors, path_length, position_errors
from sidewalk.system import SystemRun
from sidewalk.report import BlackboardUsage, ErrorSummary, RunReport, StepReport, plot_trajectory, write_report
from sidewalk.supervisor import ProcessPlan, ProcessStartError
from sidewalk.observers import RECORDING_NAME, observer_plans  # issue 11: monitor and recording
from vehicle_sim.mapgen import derive_map, displaced_by_up_to
from vehicle_sim.worldfile import WORLDS_DIR, World, load_world, world_path

__all__ = ["RunConfig", "Progress", "preflight", "build_plans", "prepare_out", "run_mission", "mission_path", "MODULES", "LaunchError"]

#: Every module of the Sidewalk system in start order (the consumers before the producers).
MODULES = ("helm", "perception", "pilot", "map_navigator", "captain")


class LaunchError(RuntimeError):
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
    # ---- monitor and recording (issue 11) ----
    record: bool = True  # write run.mcap beside report.json
    monitor_port: Optional[int] = Field(default=None, ge=1, le=65535)  # serve the monitor page on this port
    # ---- end monitor and recording ----


@dataclass
class Progress:
    """What the progress display shows."""

    step: str = "starting"
    step_index: int = 0
    step_count: int = 0
    distance_m: float = 0.0
    sim_time_s: float = 0.0
    rtf: float = 0.0
    state: str = "starting"
    namespace: str = ""
    endpoint: str = ""


def mission_path(name_or_path: str | Path) -> Path:
    """Resolve a mission name ("campus-tour") to worlds/<name>.yaml, or return an existing file path."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml", ".json") or p.exists():
        if not p.exists():
            raise FileNotFoundError(f"mission file {p} does not exist")
        return p
    candidate = WORLDS_DIR / f"{name_or_path}.yaml"
    if not candidate.exists():
        known = sorted(q.stem for q in WORLDS_DIR.glob("*.yaml"))
        raise FileNotFoundError(f"no mission named {str(name_or_path)!r} (looked for {candidate}); known: {known}")
    return candidate


def _start_pose(world: World, cfg: RunConfig) -> tuple[float, float, float]:
    """Return the PILOT's belief of the start pose: the truth moved by the requested error [m, rad].

    The error's direction is drawn from the run's seed; its size is exactly what was asked.
    """
    if world.start is None:
        raise LaunchError(f"world {world.name!r} has no start pose")
    x, y, yaw = world.start.x, world.start.y, math.radians(world.start.yaw_deg)
    if cfg.pose_error_m or cfg.pose_error_deg:
        rng = np.random.default_rng([cfg.seed, 7])
        bearing = rng.uniform(0.0, 2.0 * math.pi)
        sign = 1.0 if rng.random() < 0.5 else -1.0
        x += cfg.pose_error_m * math.cos(bearing)
        y += cfg.pose_error_m * math.sin(bearing)
        yaw += sign * math.radians(cfg.pose_error_deg)
    return x, y, yaw


def _map_file(world: World, cfg: RunConfig, out: Path) -> Path:
    """Return the map file the MAP NAVIGATOR reads: the shipped map, or one derived with --map-error."""
    if cfg.map_error_m is None:
        return world_path(cfg.world, kind="map")
    m = derive_map(world, displaced_by_up_to(cfg.map_error_m), np.random.default_rng([cfg.seed, 11]))
    return m.save(out / "map.geojson")


def _destination_xy(world: World, dest) -> Optional[tuple[float, float]]:
    if dest.xy is not None:
        return float(dest.xy[0]), float(dest.xy[1])
    if dest.place is not None:
        try:
            n = world.place(dest.place)
        except KeyError:
            return None
        return n.x, n.y
    return None


def _object_outlines(world: World) -> list[tuple[str, np.ndarray]]:
    out = []
    for o in world.objects:
        if o.polygon is not None:
            out.append((o.kind, np.asarray(o.polygon)))
        elif o.center is not None:
            out.append((o.kind, np.asarray(o.center)))
    return out


def preflight(cfg: RunConfig) -> tuple[World, Mission, Path]:
    """Load and check the world and the mission before anything starts; raise LaunchError."""
    try:
        world = load_world(cfg.world)
    except (FileNotFoundError, ValueError) as exc:
        raise LaunchError(str(exc)) from None
    try:
        mpath = mission_path(cfg.mission)
        mission = load_mission(mpath)
    except (FileNotFoundError, MissionFileError) as exc:
        raise LaunchError(str(exc)) from None
    if mission.world is not None and mission.world != world.name:
        raise LaunchError(f"mission {mission.name!r} is for world {mission.world!r}, not {world.name!r}")
    return world, mission, mpath


def build_plans(cfg: RunConfig, world: World, vehicle: str, out: Path, ns: str, endpoint: str) -> list[ProcessPlan]:
    """Return the processes of a run in start order: router, node, simulator, then the modules."""
    zflags = ("--ns", ns, "--connect", endpoint)
    sx, sy, syaw = _start_pose(world, cfg)
    map_file = _map_file(world, cfg, out)
    plans = [
        ProcessPlan("router", ("-m", "sidewalk", "up", "router", "--ns", ns, "--listen", endpoint)),
        ProcessPlan("blackboard", ("-m", "sidewalk", "up", "blackboard", *zflags,
                                   "--db", str(out / "blackboard.db"), "--types", "modules.vocabulary")),
        ProcessPlan("sim", ("-m", "sidewalk", "up", "sim", "--world", cfg.world, "--vehicle", vehicle,
                            "--rtf", str(cfg.rtf), "--seed", str(cfg.seed), "--watchdog", str(cfg.watchdog_s), *zflags)),
        ProcessPlan("helm", ("-m", "sidewalk", "up", "helm", "--vehicle", vehicle, *zflags)),
    ]
    # ---- monitor and recording (issue 11): recorder and monitor start before the simulator ----
    plans[2:2] = observer_plans(out, zflags, record=cfg.record, monitor_port=cfg.monitor_port)
    if cfg.perception:
        plans.append(ProcessPlan("perception", ("-m", "sidewalk", "up", "perception", "--vehicle", vehicle, *zflags)))
    plans += [
        ProcessPlan("pilot", ("-m", "sidewalk", "up", "pilot", "--vehicle", vehicle,
                              "--perception", "on" if cfg.perception else "off",
                              f"--start-pose={sx},{sy},{syaw}", "--seed", str(cfg.seed), *zflags)),
        ProcessPlan("map_navigator", ("-m", "sidewalk", "up", "map_navigator", "--map", str(map_file),
                                      "--vehicle", vehicle, *zflags)),
        ProcessPlan("captain", ("-m", "sidewalk", "up", "captain", *zflags)),
    ]
    return plans


def prepare_out(out: Path) -> None:
    """Create the output directory and remove what an earlier run left there."""
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("blackboard.db", "blackboard.db-wal", "blackboard.db-shm", "report.json", "trajectory.png", "map.geojson", RECORDING_NAME):
        (out / stale).unlink(missing_ok=True)
    for old_log in (out / "logs").glob("*.log"):
        old_log.unlink()


async def run_mission(cfg: RunConfig, on_progress: Callable[[Progress], None] | None = None) -> RunReport:
    """Run one mission end to end and return its report (also written to `cfg.out`)."""
    world, mission, mpath = preflight(cfg)
    out = Path(cfg.out)
    prepare_out(out)
    vehicle = cfg.vehicle or mission.vehicle or "terregator"
    ns = cfg.namespace or f"run{os.getpid()}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    system = SystemRun(build_plans(cfg, world, vehicle, out, ns, endpoint), ns=ns, endpoint=endpoint, log_dir=out / "logs")
    progress = Progress(step_count=len(mission.steps), namespace=ns, endpoint=endpoint)
    status: MissionStatus | None = None
    reason = ""
    wall_mission0 = time.monotonic()
    sim0: float | None = None
    routes: list[tuple[int, int, np.ndarray]] = []
    stats: dict = {}
    try:
        def starting(name: str) -> None:
            progress.step = f"starting {name}"
            if on_progress:
                on_progress(progress)

        try:
            await system.start(on_starting=starting)
        except ProcessStartError as exc:
            raise LaunchError(str(exc)) from None
        mission_id = await system.submit(mpath.read_text())
        wall_mission0 = time.monotonic()
        deadline = wall_mission0 + cfg.max_wall_time_s
        while True:
            if system.recorder.clock is not None and sim0 is None:
                sim0 = system.recorder.clock.stamp
            st = await system.next_status(mission_id, timeout=0.5)
            if st is not None:
                status = st
            for dead in system.crashed():
                progress.state = f"{dead} exited"
            progress.sim_time_s = system.recorder.sim_time - (sim0 or 0.0)
            progress.distance_m = system.recorder.distance_m()
            progress.rtf = progress.sim_time_s / max(1e-6, time.monotonic() - wall_mission0)
            if status is not None:
                progress.state = status.state
                if status.current_step is not None:
                    progress.step_index = status.current_step
                    progress.step = status.steps[status.current_step].name if status.steps else ""
                if status.terminal:
                    reason = status.reason
                    break
            if on_progress:
                on_progress(progress)
            if progress.sim_time_s > cfg.max_sim_time_s:
                reason = f"sim-time budget of {cfg.max_sim_time_s:.0f} s used up"
                break
            if time.monotonic() > deadline:
                reason = f"wall-time budget of {cfg.max_wall_time_s:.0f} s used up"
                break
        routes = await system.route_plans(mission_id)
        stats = await system.blackboard_stats()
    finally:
        cpu, exit_codes = await system.close()
    wall = time.monotonic() - wall_mission0
    recorder = system.recorder
    truth = recorder.truth.array() if recorder else np.zeros((0, 4))
    est = recorder.estimate.array() if recorder else np.zeros((0, 4))
    # the newest revision of each step's route
    newest: dict[int, tuple[int, np.ndarray]] = {}
    for step_index, revision, poly in routes:
        if step_index not in newest or revision > newest[step_index][0]:
            newest[step_index] = (revision, poly)
    route = np.concatenate([newest[k][1] for k in sorted(newest)]) if newest else None
    sim_time = float(truth[-1, 0] - truth[0, 0]) if len(truth) >= 2 else 0.0
    # distance to the nearest of every route the mission had (replans included)
    cte = (np.min([cross_track_errors(truth[:, 1:3], poly) for _, _, poly in routes if len(poly) >= 2], axis=0)
           if routes and len(truth) else np.zeros(0))
    pe = position_errors(est[:, 0], est[:, 1:3], truth[:, 0], truth[:, 1:3]) if len(est) else np.zeros(0)
    goal = _destination_xy(world, mission.steps[-1].destination)
    goal_error = float(math.hypot(truth[-1, 1] - goal[0], truth[-1, 2] - goal[1])) if goal and len(truth) else None
    steps = []
    if status is not None:
        for s in status.steps:
            steps.append(StepReport(name=s.name, success=s.state == "succeeded", sim_time_s=s.finished_at, reason=s.reason))
    success = bool(status is not None and status.state == "succeeded")
    report = RunReport(
        success=success,
        reason=reason if not success else "",
        mission=mission.name,
        world=world.name,
        vehicle=vehicle,
        seed=cfg.seed,
        perception=cfg.perception,
        pose_error=(cfg.pose_error_m, cfg.pose_error_deg),
        map_error_m=cfg.map_error_m or 0.0,
        sim_time_s=round(sim_time, 3),
        wall_time_s=round(wall, 3),
        rtf_requested=cfg.rtf,
        rtf_achieved=round(sim_time / wall, 3) if wall > 0 else 0.0,
        distance_m=round(path_length(truth[:, 1:3]), 3),
        steps=steps,
        cross_track_error_m=ErrorSummary(**_stats(cte)),
        position_error_m=ErrorSummary(**_stats(pe)),
        goal_error_m=None if goal_error is None else round(goal_error, 3),
        collisions=recorder.collisions() if recorder else 0,
        off_path_s=round(recorder.off_path_s(truth[-1, 0]) if recorder and len(truth) else 0.0, 3),
        sim_events=dict(Counter(e.kind for e in recorder.events)) if recorder else {},
        blackboard=BlackboardUsage(**_bb_usage(stats)),
        modules={k: round(v, 3) for k, v in cpu.items()},
        exit_codes=exit_codes,
    )
    write_report(report, out)
    plot_trajectory(
        out / "trajectory.png",
        objects=_object_outlines(world),
        route=route,
        truth=truth[:, 1:3] if len(truth) else None,
        estimate=est[:, 1:3] if len(est) else None,
        title=f"{mission.name} on {world.name} ({vehicle}, seed {cfg.seed}) — {'success' if success else 'FAILED'}",
    )
    return report


def _stats(e: np.ndarray) -> dict:
    if e.size == 0:
        return {}
    return {"rms": round(float(np.sqrt(np.mean(e**2))), 4), "max": round(float(e.max()), 4), "final": round(float(e[-1]), 4)}


def _bb_usage(stats: dict) -> dict:
    """Map the node's counters onto the report's blackboard fields (the rest kept as extras)."""
    if not stats:
        return {}
    d = {str(k): v for k, v in stats.items()}
    usage = {
        "posts": int(d.get("posts", 0)),
        "retrieves": int(d.get("retrieves", 0)),
        "monitors": int(d.get("monitors_registered", d.get("monitors", 0))),
        "bytes": int(d.get("bytes_in", 0)) + int(d.get("bytes_out", 0)),
    }
    for k, v in d.items():
        if k not in usage and isinstance(v, (int, float)):
            usage[k] = v
    return usage
