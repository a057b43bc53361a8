"""`sidewalk run`: the router, the simulator and every module of an architecture as OS processes on loopback.

The launcher is the same for CODGER and EDDIE (`sidewalk.architecture`: what each prepares, its process
plans and its observer). It gives the robot the shipped map or one derived with `--map-error`, its start
from the mission's (or else the map's) start plus `--pose-error`, starts each process and waits for its
ready line, submits the mission to the mission service over Zenoh (as `sidewalk submit` does), follows
the mission status (the architecture's observer), records the run (truth, estimates, events,
statuses, route plans, heartbeats) into a `RunRecord`, builds the report from it, and stops
everything — also on Ctrl-C.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from shapely import LineString, Point
from sidewalk.architecture import architecture
from sidewalk.observers import RECORDING_NAME  # issue 11: monitor and recording

from sidewalk.compare.faults import inject_fault  # issue 10: fault injection

from modules.captain.missionfile import MissionFileError, load_mission
from modules.vocabulary import Destination, Mission
from sidewalk.lane_goal import judged_goals
from sidewalk.map_error import measure_map_error
from sidewalk.missions import mission_path
from sidewalk.robot_map import map_beside
from sidewalk.recorder import RECORD_LEAD_S
from sidewalk.report import RunReport, build_report, plot_trajectory, write_report
from sidewalk.run_record import FaultEvent, RecordedPlan, RunRecord, save_record
from sidewalk.run_setup import LaunchError, RunConfig, RunSetup
from sidewalk.supervisor import ProcessPlan, ProcessStartError
from sidewalk.system import SystemRun
from vehicle_sim.mapgen import map_with_error
from vehicle_sim.worldfile import WORLDS_DIR, World, WorldFileError, load_world, world_path
from wire.timemode import LOCKSTEP_ENV, lockstep_env
from wire.ports import free_port

__all__ = [
    "RunConfig", "RunSetup", "Progress", "preflight", "prepare_run", "prepare_out", "run_mission",
    "mission_path", "LaunchError", "RECORD_FILE", "record_run", "lockstep_plans",
]

#: The run record's file name in the output directory.
RECORD_FILE = "run_record.json"

#: Processes a lock-step simulator does not wait for: nothing the run does depends on them (only their hash seed is fixed).
LOCKSTEP_BYSTANDERS = ("router", "recorder", "monitor")

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


def _with_pose_error(pose: tuple[float, float, float], cfg: RunConfig) -> tuple[float, float, float]:
    """Return `pose` (x, y [m], yaw [rad]) moved by the requested error; its direction is drawn from the run's seed."""
    x, y, yaw = pose
    if cfg.pose_error_m or cfg.pose_error_deg:
        rng = np.random.default_rng([cfg.seed, 7])
        bearing = rng.uniform(0.0, 2.0 * math.pi)
        sign = 1.0 if rng.random() < 0.5 else -1.0
        x += cfg.pose_error_m * math.cos(bearing)
        y += cfg.pose_error_m * math.sin(bearing)
        yaw += sign * math.radians(cfg.pose_error_deg)
    return x, y, yaw


def _map(world: World, cfg: RunConfig, out: Path) -> tuple[Path, World]:
    """Return the map file the MAP NAVIGATOR reads and the map: the shipped one, or one derived with --map-error."""
    if cfg.map_file is not None:  # issue 12: a map built by `sidewalk mapbuild`
        try:
            return Path(cfg.map_file), load_world(cfg.map_file, kind="map")
        except (FileNotFoundError, ValueError) as exc:
            raise LaunchError(f"--map {cfg.map_file}: {exc}") from None
    if cfg.map_error_m is None:
        try:
            path = map_beside(cfg.world)
            return path, load_world(path, kind="map")
        except (FileNotFoundError, ValueError) as exc:
            raise LaunchError(str(exc)) from None
    m = map_with_error(world, cfg.map_error_m, np.random.default_rng([cfg.seed, 11]))
    return m.save(out / "map.geojson"), m


def _destination_xy(world: World, dest: Destination) -> Optional[tuple[float, float]]:
    """Return a step's true destination (x, y) [m] in `world`: the place (or node) it names, or its point on the nearest path."""
    if dest.xy is not None:
        if not world.edges or dest.off_road:
            return float(dest.xy[0]), float(dest.xy[1])
        p = Point(dest.xy)
        on = min((LineString(e.coords) for e in world.edges), key=lambda line: line.distance(p))
        q = on.interpolate(on.project(p))
        return float(q.x), float(q.y)
    assert dest.place is not None
    try:
        n = world.place(dest.place)
    except KeyError:
        try:
            n = world.node(dest.place)
        except KeyError:
            return None
    return n.x, n.y


def _object_outlines(world: World) -> list[tuple[str, np.ndarray]]:
    out = []
    for o in world.objects:
        if o.polygon is not None:
            out.append((o.kind, np.asarray(o.polygon)))
        elif o.center is not None:
            out.append((o.kind, np.asarray(o.center)))
    return out


def _one_line(exc: Exception) -> str:
    """Return a file error in one line: the problems of a world or map file joined (the first three)."""
    if isinstance(exc, WorldFileError):
        more = f"; and {len(exc.problems) - 3} more" if len(exc.problems) > 3 else ""
        return "; ".join(str(p) for p in exc.problems[:3]) + more
    return str(exc)


def preflight(cfg: RunConfig) -> tuple[World, Mission, Path]:
    """Load and check the world and the mission before anything starts; raise LaunchError."""
    try:
        world = load_world(cfg.world)
        if cfg.map_file is None and cfg.map_error_m is None:  # the robot's map: beside the world, never the world
            map_beside(cfg.world)
    except (FileNotFoundError, ValueError) as exc:
        raise LaunchError(str(exc)) from None
    if cfg.map_file is not None:
        try:
            load_world(cfg.map_file, kind="map")
        except (FileNotFoundError, ValueError) as exc:
            raise LaunchError(f"--map {cfg.map_file}: {_one_line(exc)}") from None
    try:
        mpath = mission_path(cfg.mission)
        mission = load_mission(mpath)
    except (FileNotFoundError, MissionFileError) as exc:
        raise LaunchError(str(exc)) from None
    if mission.world is not None and mission.world != world.name:
        raise LaunchError(f"mission {mission.name!r} is for world {mission.world!r}, not {world.name!r}")
    for i, step in enumerate(mission.steps):  # an unknown destination is refused before anything starts
        if step.destination.place is not None and _destination_xy(world, step.destination) is None:
            raise LaunchError(f"{mpath}: steps[{i}].destination: unknown place {step.destination.place!r} in world "
                              f"{world.name!r}; known places: {', '.join(sorted(world.place_names()))}")
    if cfg.actors:  # issue 12: a bad actors file fails here, not in the simulator
        from vehicle_sim.actors import ActorError, load_actors

        try:
            load_actors(cfg.actors)
        except ActorError as exc:
            raise LaunchError(f"--actors: {exc}") from None
    if cfg.road_method == "alvinn" or cfg.alvinn_weights is not None:  # issue 13: bad weights fail here, not in a module
        from modules.road_following import RoadFollowingError, load_alvinn_weights

        try:
            load_alvinn_weights(cfg.alvinn_weights)
        except RoadFollowingError as exc:
            raise LaunchError(f"--alvinn-weights: {exc}") from None
    return world, mission, mpath


def prepare_run(cfg: RunConfig) -> RunSetup:
    """Check the run, clear `cfg.out`, write the map the robot gets (with --map-error) and work out the start poses."""
    world, mission, mpath = preflight(cfg)
    out = Path(cfg.out)
    prepare_out(out)
    map_file, map_ = _map(world, cfg, out)
    if mission.start is not None:
        start_truth = (mission.start.x, mission.start.y, math.radians(mission.start.yaw_deg))
        told = start_truth
    elif map_.start is not None:
        start_truth = None
        told = (map_.start.x, map_.start.y, math.radians(map_.start.yaw_deg))
    else:
        raise LaunchError(f"the map {map_file} has no start pose and mission {mission.name!r} gives none (add start: {{x, y, yaw_deg}})")
    vehicle = cfg.vehicle or mission.vehicle or "terregator"
    dests = tuple(_destination_xy(world, s.destination) for s in mission.steps)
    true_start = start_truth or ((world.start.x, world.start.y, 0.0) if world.start is not None else told)
    goals = judged_goals(world, mission.steps, dests, true_start[:2], vehicle=vehicle)
    return RunSetup(
        world=world, mission=mission, mission_file=mpath, vehicle=vehicle,
        map_file=map_file, map_error=measure_map_error(world, map_, requested_m=cfg.map_error_m),
        start_truth=start_truth, start_belief=_with_pose_error(told, cfg),
        destinations=dests, lane_offsets=tuple(0.0 if g is None else g.offset_m for g in goals),
        goal_points=tuple(None if g is None else g.point for g in goals),
    )


def lockstep_plans(plans: list[ProcessPlan]) -> list[ProcessPlan]:
    """Return `plans` run in lock-step: the simulator with `--lockstep`, every process with the lock-step environment.

    The environment (`wire.lockstep.lockstep_env`) makes each module, the blackboard node and each
    EDDIE module a barrier participant, switches their wall-clock caps to counts and fixes
    PYTHONHASHSEED (the order of sets of strings). The router and the observers (recorder, monitor)
    decide nothing the run depends on: they stay out of the barrier, so the simulator never waits for them.
    """
    env = lockstep_env()
    bystander = tuple(kv for kv in env if kv[0] != LOCKSTEP_ENV)
    return [replace(p, args=(*p.args, "--lockstep") if p.name == "sim" else p.args,
                    env=(*p.env, *(bystander if p.name in LOCKSTEP_BYSTANDERS else env))) for p in plans]


def _timed(cfg: RunConfig, plans: list[ProcessPlan]) -> list[ProcessPlan]:
    """Return the plans in the run's time mode (lock-step or real time)."""
    return lockstep_plans(plans) if cfg.lockstep else plans


def prepare_out(out: Path) -> None:
    """Create the output directory and remove what an earlier run left there."""
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("blackboard.db", "blackboard.db-wal", "blackboard.db-shm", "report.json", "trajectory.png", "map.geojson",
                  RECORD_FILE, RECORDING_NAME, "annotated_map.geojson"):
        (out / stale).unlink(missing_ok=True)
    for old_log in (out / "logs").glob("*.log"):
        old_log.unlink()


def record_run(system: SystemRun, cfg: RunConfig, setup: RunSetup, mission_id: str, exit_codes: dict[str, Optional[int]],
               *, stop_reason: str = "", gave_up_at: tuple[float, float] | None = None,
               faults: tuple[FaultEvent, ...] = ()) -> RunRecord:
    """Return the record of a run observed by `system` (after `finish` and `close`).

    The run ends when the mission's terminal status was received, else when the launcher gave up
    (`gave_up_at`: wall, sim [s] as `SystemRun.stamps`; `stop_reason` says why), else at the newest status.
    """
    rec = system.recorder
    if rec is None or mission_id not in system.submitted:
        raise LaunchError("the system stopped before the mission was submitted")
    submitted_wall, submitted_sim = system.submitted[mission_id]
    statuses = system.statuses.get(mission_id, [])
    terminal = next((s for s in statuses if s.status.terminal), None)
    end = terminal or (statuses[-1] if statuses else None)
    ended_wall = end.wall_s if end is not None else submitted_wall
    ended_sim = end.sim_s if end is not None and end.sim_s is not None else submitted_sim
    if terminal is not None and terminal.status.finished_at is not None:
        # the mission service's own stamp: the observer hears it a varying moment later (in lock-step too, being
        # outside the barrier), and the record's window ends from it
        ended_sim = terminal.status.finished_at
    if terminal is None and gave_up_at is not None:
        ended_wall, ended_sim = gave_up_at
    # what happened while the system started, or after the vehicle came to rest, is no part of the mission
    rest = system.rest.get(mission_id)
    kept_from, kept_to = submitted_sim - RECORD_LEAD_S, (math.inf if rest is None else max(rest, ended_sim) + RECORD_LEAD_S)
    return RunRecord(
        architecture=cfg.arch, mission=setup.mission, world=setup.world.name, vehicle=setup.vehicle, seed=cfg.seed,
        world_file=str(Path(cfg.world).resolve()) if Path(cfg.world).suffix in (".geojson", ".json") else None,
        perception=cfg.perception, pose_error=(cfg.pose_error_m, cfg.pose_error_deg), map_error=setup.map_error,
        rtf_requested=cfg.rtf, time_mode=cfg.time_mode, destinations=setup.destinations, lane_offsets=setup.lane_offsets,
        goal_points=setup.goal_points,
        submitted_wall_s=round(submitted_wall, 6), submitted_sim_s=submitted_sim,
        ended_wall_s=round(ended_wall, 6), ended_sim_s=ended_sim, rest_sim_s=rest,
        stop_reason=stop_reason,
        truth=tuple(r for r in rec.truth.rows if kept_from <= r[0] <= kept_to),
        estimate=tuple(r for r in rec.estimate.rows if kept_from <= r[0] <= kept_to),
        events=tuple(e for e in rec.events if kept_from <= e.stamp <= kept_to),
        statuses=tuple(statuses), plans=tuple(system.routes.get(mission_id, ())), processes=rec.process_costs(),
        blackboard=system.bb_stats, exit_codes=exit_codes, actors=cfg.actors,
        triggers=tuple(t for t in getattr(system, "triggers", ()) if kept_from <= t.sim_s <= kept_to),
        faults=faults, max_speed=cfg.max_speed,
        restarts=tuple(system.sup.restarts), wedges=tuple(system.sup.wedges), gave_up=tuple(system.sup.gave_up),
    )


async def run_mission(cfg: RunConfig, on_progress: Callable[[Progress], None] | None = None) -> RunReport:
    """Run one mission end to end; write `run_record.json`, `report.json` and `trajectory.png` to `cfg.out`; return the report."""
    setup = prepare_run(cfg)
    out = Path(cfg.out)
    ns = cfg.namespace or f"run{os.getpid()}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    arch = architecture(cfg.arch)
    prepared = arch.prepare(setup, out)
    system = arch.system(_timed(cfg, arch.plans(cfg, setup, ns, endpoint, prepared)), ns=ns, endpoint=endpoint,
                         log_dir=out / "logs", prepared=prepared, secure=cfg.secure, lockstep=cfg.lockstep)
    progress = Progress(step_count=len(setup.mission.steps), namespace=ns, endpoint=endpoint)
    stop_reason = ""
    gave_up_at: tuple[float, float] | None = None
    mission_id: str | None = None
    fault_events: list[FaultEvent] = []
    try:
        def starting(name: str) -> None:
            progress.step = f"starting {name}"
            if on_progress:
                on_progress(progress)

        try:
            await system.start(on_starting=starting)
        except ProcessStartError as exc:
            raise LaunchError(str(exc)) from None
        notices: list[str] = []
        system.sup.on_notice = notices.append
        system.guard(cfg.supervise)  # issue 14: crashed modules restarted with back-off, wedged ones reported and restarted
        mission_id = await system.submit(setup.mission_file.read_text())
        if cfg.lockstep:  # every run's mission starts at the same step: the simulator held at 0 steps on now
            await system.release_lockstep()
        submitted_wall, submitted_sim = system.submitted[mission_id]
        deadline = time.monotonic() + cfg.max_wall_time_s
        pending = sorted(cfg.faults, key=lambda f: f.at_s)  # issue 10
        while True:
            st = await system.next_status(mission_id, timeout=0.5)
            now_wall, now_sim = system.stamps()
            for dead in system.crashed():
                progress.state = f"{dead} exited"
            while notices:
                progress.state = notices.pop(0)[:60]
            progress.sim_time_s = now_sim - submitted_sim
            progress.distance_m = system.recorder.distance_m() if system.recorder else 0.0
            progress.rtf = progress.sim_time_s / max(1e-6, now_wall - submitted_wall)
            if st is not None:
                progress.state = st.state
                if st.current_step is not None:
                    progress.step_index = st.current_step
                    progress.step = st.steps[st.current_step].name if st.steps else ""
                if st.terminal:
                    break
            if on_progress:
                on_progress(progress)
            while pending and progress.sim_time_s >= pending[0].at_s:  # issue 10: inject each fault once its time came
                spec = pending.pop(0)
                progress.state = f"injecting {spec.name}"
                fault_events.append(await inject_fault(system, spec, getattr(cfg, "arch", "codger")))
            if system.sup.gave_up:
                g = system.sup.gave_up[0]
                stop_reason = f"{g.module} crash-looped ({g.failures} failed lives in a row, last: {g.reason}); the supervisor gave up on it"
            elif progress.sim_time_s > cfg.max_sim_time_s:
                stop_reason = f"sim-time budget of {cfg.max_sim_time_s:.0f} s used up"
            elif time.monotonic() > deadline:
                stop_reason = f"wall-time budget of {cfg.max_wall_time_s:.0f} s used up"
            if stop_reason:
                gave_up_at = (now_wall, now_sim)
                break
        await system.finish(mission_id)
    finally:
        exit_codes = await system.close()
    record = record_run(system, cfg, setup, mission_id or "", exit_codes, stop_reason=stop_reason, gave_up_at=gave_up_at,
                        faults=tuple(fault_events))
    save_record(record, out / RECORD_FILE)
    report = build_report(record)
    write_report(report, out)
    _plot(out / "trajectory.png", record, setup, report)
    return report


def _plot(path: Path, record: RunRecord, setup: RunSetup, report: RunReport) -> None:
    """Draw the run: the world, each step's newest route, the true and the estimated track."""
    newest: dict[int, RecordedPlan] = {}
    for p in record.plans:
        if p.step_index not in newest or p.revision > newest[p.step_index].revision:
            newest[p.step_index] = p
    route = np.concatenate([np.asarray(newest[k].polyline) for k in sorted(newest)]) if newest else None
    truth = np.asarray(record.truth, dtype=float).reshape(-1, 4)
    est = np.asarray(record.estimate, dtype=float).reshape(-1, 4)
    verdict = "success" if report.success else "FAILED" + (" (claimed success)" if report.claimed_success else "")
    plot_trajectory(
        path,
        objects=_object_outlines(setup.world),
        route=route,
        truth=truth[:, 1:3] if len(truth) else None,
        estimate=est[:, 1:3] if len(est) else None,
        title=f"{setup.mission.name} on {setup.world.name} ({setup.vehicle}, seed {record.seed}) — {verdict}",
    )
