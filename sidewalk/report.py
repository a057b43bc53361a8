"""The run report: `report.json`, built by `build_report` from a recorded run alone, and `trajectory.png`.

`success` is judged from truth: every step's destination truly reached within its tolerance when
the step ended, and no collision. A step kept to a side is judged at its destination in that lane,
on the route's direction of travel (`RunRecord.goal_points`, `sidewalk.lane_goal`), never by the
vehicle's heading. The robot's own verdict is `claimed_success`; when the two
disagree, `reason` says how. Times are spans from the mission's submission [s]; cross-track error
is measured against each step's first route plan (the route centreline, so a keep-right offset
counts), replans separately: their number, and the error against the plan in force at each moment.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from typing import Literal, Optional, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

from modules.vocabulary import MissionStatus, StepOutcome
from sidewalk.json_out import dumps
from sidewalk.map_error import MapErrorSummary
from sidewalk.metrics import cross_track_errors, interpolate_track, path_length, position_errors
from sidewalk.run_record import FaultEvent, FiredTrigger, RunRecord
from sidewalk.stops import StopSummary, stop_summary
from sidewalk.supervisor import GiveUp, Restart, WedgeReport
from wire.drive import SimEvent

__all__ = [
    "StepReport",
    "ErrorSummary",
    "BlackboardUsage",
    "ModuleCost",
    "RunReport",
    "build_report",
    "write_report",
    "plot_trajectory",
    "KIND_COLOURS",
]


class ErrorSummary(BaseModel):
    """An error series summarised [m]: root mean square, largest, last; n samples."""

    model_config = ConfigDict(frozen=True)

    rms: Optional[float] = None
    max: Optional[float] = None
    final: Optional[float] = None
    n: int = 0

    @classmethod
    def of(cls, e: np.ndarray) -> "ErrorSummary":
        """Summarise errors (N,) [m]; an empty series gives None figures and n = 0."""
        e = np.asarray(e, dtype=float)
        if e.size == 0:
            return cls()
        return cls(rms=round(float(np.sqrt(np.mean(e**2))), 4), max=round(float(e.max()), 4),
                   final=round(float(e[-1]), 4), n=int(e.size))


class StepReport(BaseModel):
    """One mission step: truth's verdict and the robot's, when it started and ended [s] from submission (sim).

    `distance_m` is the true distance [m] from the vehicle to the step's destination as judged: for
    an intermediate step the closest the vehicle came between the step's start and the next step's
    end, for the last step where the vehicle came to rest; `success` is `distance_m <= tolerance_m`.
    `distance_at_claim_m` is the true distance when the robot said the step was done.
    Cross-track error is against the step's first plan; `..._newest_m` against the newest plan in
    force at each moment (the first until a replan was posted).
    """

    model_config = ConfigDict(frozen=True)

    name: str
    success: bool
    claimed_success: bool
    state: str
    reason: str = ""
    tolerance_m: float
    distance_m: Optional[float] = None
    distance_at_claim_m: Optional[float] = None
    started_s: Optional[float] = None
    finished_s: Optional[float] = None
    replans: int = 0
    cross_track_error_m: ErrorSummary = ErrorSummary()
    cross_track_error_newest_m: ErrorSummary = ErrorSummary()


class BlackboardUsage(BaseModel):
    """What the blackboard node counted during the run."""

    model_config = ConfigDict(frozen=True, extra="allow")

    posts: int = 0
    retrieves: int = 0
    monitors: int = 0
    bytes: int = 0


class ModuleCost(BaseModel):
    """What one process cost, from its last heartbeat: CPU [s], resident memory [MB], Zenoh traffic.

    A process started more than once (`incarnations` > 1) sums CPU and traffic over its lives and
    gives the largest resident memory.
    """

    model_config = ConfigDict(frozen=True)

    cpu_s: float
    rss_mb: float
    msgs_out: int
    bytes_out: int
    msgs_in: int
    bytes_in: int
    incarnations: int = 1
    #: of the traffic above, the lock-step barrier's asks and answers: the run mode's cost (0 in real time)
    barrier_msgs_out: int = 0
    barrier_bytes_out: int = 0


class RunReport(BaseModel):
    """Everything a run measured; written as `report.json`. Times [s] count from submission (see `build_report`)."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    success: bool
    claimed_success: bool
    reason: str = ""
    mission: str
    world: str
    vehicle: str
    seed: int
    perception: bool
    pose_error: tuple[float, float] = (0.0, 0.0)
    map_error: Optional[MapErrorSummary] = None
    sim_time_s: float
    wall_time_s: float
    rtf_requested: float
    #: how sim time advanced: `realtime` (at `rtf_requested`) or `lockstep` (the simulator waited for every module)
    time_mode: Literal["realtime", "lockstep"] = "realtime"
    rtf_achieved: float
    distance_m: float
    steps: list[StepReport]
    goal_error_m: Optional[float] = None
    cross_track_error_m: ErrorSummary
    cross_track_error_newest_m: ErrorSummary
    replans: int
    position_error_m: ErrorSummary
    collisions: int
    off_path_s: float
    sim_events: dict[str, int] = {}
    blackboard: Optional[BlackboardUsage] = None
    modules: dict[str, ModuleCost] = {}
    exit_codes: dict[str, Optional[int]] = {}
    stops: Optional[StopSummary] = None  # issue 12: stops on the way, time stopped, closest approach to actors
    #: EDDIE: the triggers fired, sim times [s] counted from submission like every other time here
    triggers: list[FiredTrigger] = []
    #: issue 10: faults injected (`--fault`), the speed cap (`--max-speed`) [m/s], the mean true speed [m/s] over the mission
    faults: list[FaultEvent] = []
    max_speed: Optional[float] = None
    mean_speed_m_s: Optional[float] = None
    #: issue 14: what the supervisor of `sidewalk run` did; `at_s` [s] wall since the system started
    restarts: list[Restart] = []
    wedges: list[WedgeReport] = []
    gave_up: list[GiveUp] = []


def _final_status(rec: RunRecord) -> MissionStatus | None:
    return rec.statuses[-1].status if rec.statuses else None


def _window(track: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """Return the rows of a track (N,4) stamped in [t0, t1] [s]."""
    return track[(track[:, 0] >= t0) & (track[:, 0] <= t1)] if len(track) else track


def _true_pose_at(truth: np.ndarray, t: float) -> np.ndarray:
    """Return the true track row (1,4: t, x, y, yaw) at sim time t [s], interpolated (yaw unwrapped)."""
    ts = truth[:, 0]
    yaw = np.unwrap(truth[:, 3])
    return np.array([[t, np.interp(t, ts, truth[:, 1]), np.interp(t, ts, truth[:, 2]), np.interp(t, ts, yaw)]])


def _off_path_s(events: Sequence[SimEvent], t0: float, t1: float) -> float:
    """Return the sim time [s] spent off the path objects between t0 and t1 [s]."""
    total, since = 0.0, None
    for e in sorted(events, key=lambda e: e.stamp):
        if e.kind == "off-path" and since is None:
            since = e.stamp
        elif e.kind == "on-path" and since is not None:
            total += max(0.0, min(e.stamp, t1) - max(since, t0))
            since = None
    if since is not None:
        total += max(0.0, t1 - max(since, t0))
    return total


def _module_costs(rec: RunRecord) -> dict[str, ModuleCost]:
    out: dict[str, ModuleCost] = {}
    for name in sorted({p.name for p in rec.processes}):
        lives = [p.usage for p in rec.processes if p.name == name]
        out[name] = ModuleCost(
            cpu_s=round(sum(u.cpu_s for u in lives), 3), rss_mb=round(max(u.rss_bytes for u in lives) / 1e6, 1),
            msgs_out=sum(u.msgs_out for u in lives), bytes_out=sum(u.bytes_out for u in lives),
            msgs_in=sum(u.msgs_in for u in lives), bytes_in=sum(u.bytes_in for u in lives), incarnations=len(lives),
            barrier_msgs_out=sum(u.barrier_msgs_out for u in lives), barrier_bytes_out=sum(u.barrier_bytes_out for u in lives),
        )
    return out


def _bb_usage(stats: dict[str, int | float] | None) -> BlackboardUsage | None:
    """Map the node's counters onto the report's blackboard fields (the rest kept as extras)."""
    if stats is None:
        return None
    d = dict(stats)
    usage = {
        "posts": int(d.get("posts", 0)),
        "retrieves": int(d.get("retrieves", 0)),
        "monitors": int(d.get("monitors_registered", d.get("monitors", 0))),
        "bytes": int(d.get("bytes_in", 0)) + int(d.get("bytes_out", 0)),
    }
    for k, v in d.items():
        if k not in usage:
            usage[k] = v
    return BlackboardUsage(**usage)


def _distance_to(truth: np.ndarray, point: tuple[float, float]) -> np.ndarray:
    """Return the distance [m] of each track row (N,4: t, x, y, yaw) from `point` (x, y) [m]; the heading plays no part."""
    return np.hypot(truth[:, 1] - point[0], truth[:, 2] - point[1])


def _goal_point(rec: RunRecord, i: int) -> Optional[tuple[float, float]]:
    """Return where step i is judged: its point in its lane (`RunRecord.goal_points`), else its destination."""
    if i < len(rec.goal_points):
        return rec.goal_points[i]
    return rec.destinations[i]


def _step_report(rec: RunRecord, i: int, outcomes: dict[int, StepOutcome], origin: float, truth: np.ndarray,
                 settled: float) -> tuple[StepReport, np.ndarray, np.ndarray]:
    """Judge step i; return its report and its cross-track errors against the first and the newest plan [m].

    An intermediate step counts as reached when the true track came within its tolerance between the
    step's start and the next step's end (the robot declares arrival at an exit gate short of the
    destination and drives on through it); the last step when the vehicle came to rest within it.
    """
    spec = rec.mission.steps[i]
    outcome = outcomes.get(i)
    state = outcome.state if outcome is not None else "pending"
    started = outcome.started_at if outcome is not None else None
    finished = outcome.finished_at if outcome is not None else None
    last = i == len(rec.mission.steps) - 1
    nxt = outcomes.get(i + 1)
    judged_until = settled if last else (nxt.finished_at if nxt is not None and nxt.finished_at is not None else settled)
    dest = _goal_point(rec, i)
    distance = at_claim = None
    if started is not None and dest is not None and len(truth):
        if last:
            rest = _window(truth, started, settled)
            distance = float(_distance_to(rest[-1:], dest)[0]) if len(rest) else None
        else:
            seen = _window(truth, started, judged_until)
            distance = float(_distance_to(seen, dest).min()) if len(seen) else None
        if finished is not None and len(truth):
            at_claim = round(float(_distance_to(_true_pose_at(truth, finished), dest)[0]), 3)
    plans = sorted((p for p in rec.plans if p.step_index == i), key=lambda p: p.revision)
    cte_first = cte_newest = np.zeros(0)
    if plans and started is not None:
        rows = _window(truth, started, finished if finished is not None else rec.ended_sim_s)
        per_plan = np.array([cross_track_errors(rows[:, 1:3], np.asarray(p.polyline)) for p in plans]).reshape(len(plans), -1)
        cte_first = per_plan[0]
        # the plan in force at each sample: the newest one posted by then (the first before any was posted)
        in_force = np.maximum(np.searchsorted(np.array([p.stamp for p in plans]), rows[:, 0], side="right") - 1, 0)
        cte_newest = per_plan[in_force, np.arange(len(rows))]
    report = StepReport(
        name=spec.name, success=distance is not None and distance <= spec.tolerance, claimed_success=state == "succeeded",
        state=state, reason=outcome.reason if outcome is not None else "", tolerance_m=spec.tolerance,
        distance_m=None if distance is None else round(distance, 3), distance_at_claim_m=at_claim,
        started_s=None if started is None else round(started - origin, 3),
        finished_s=None if finished is None else round(finished - origin, 3),
        replans=max(0, len(plans) - 1), cross_track_error_m=ErrorSummary.of(cte_first),
        cross_track_error_newest_m=ErrorSummary.of(cte_newest),
    )
    return report, cte_first, cte_newest


def _disagreement(claimed: bool, claimed_reason: str, steps: list[StepReport], collisions: int, stranded: tuple[str, ...] = ()) -> str:
    """Name why truth and claim differ (or the claimed reason when both say failure)."""
    misses = [f"step {i + 1} {s.name!r} " + ("was never reached" if s.distance_m is None else
                                             f"ended {s.distance_m:.2f} m from its destination (tolerance {s.tolerance_m:.2f} m)")
              for i, s in enumerate(steps) if not s.success]
    truth = misses + ([f"{collisions} collision(s)"] if collisions else []) + [f"the vehicle {k}" for k in stranded]
    if claimed and truth:
        return "the robot claimed success, but by truth " + "; ".join(truth)
    if not claimed and not truth:
        return f"the robot claimed failure ({claimed_reason or 'no reason given'}), but by truth every destination was reached without collision"
    return claimed_reason


def build_report(rec: RunRecord) -> RunReport:
    """Return the report of a recorded run (a pure function of the record).

    Times span submission to the mission's end: `sim_time_s` by the CAPTAIN's clock (as the steps'
    times), `wall_time_s` and `rtf_achieved` (sim over wall) over the same interval as the launcher
    saw it. What the vehicle did (distance, collisions, off-path time, position error, goal error)
    spans submission until it came to rest after the end.
    """
    truth_all = np.asarray(rec.truth, dtype=float).reshape(-1, 4)
    est_all = np.asarray(rec.estimate, dtype=float).reshape(-1, 4)
    t0, t1 = rec.submitted_sim_s, rec.ended_sim_s
    settled = max(t1, rec.rest_sim_s) if rec.rest_sim_s is not None else t1
    truth = _window(truth_all, t0, settled)
    est = _window(est_all, t0, settled)
    final = _final_status(rec)
    origin = final.submitted_at if final is not None and final.submitted_at is not None else t0
    outcomes = {o.step_index: o for o in final.steps} if final is not None else {}
    steps, ctes, ctes_newest = [], [], []
    for i in range(len(rec.mission.steps)):
        sr, c, cn = _step_report(rec, i, outcomes, origin, truth_all, settled)
        steps.append(sr)
        ctes.append(c)
        ctes_newest.append(cn)
    events = [e for e in rec.events if t0 <= e.stamp <= settled]
    collisions = sum(1 for e in events if e.kind == "collision")
    # on rough ground (issue 40) the simulator's truth also says when the vehicle tipped over or high-centred
    stranded = tuple(sorted({"tipped over" if e.kind == "tip-over" else "high-centred" for e in events
                             if e.kind in ("tip-over", "high-centred")}))
    claimed = final is not None and final.state == "succeeded"
    success = all(s.success for s in steps) and collisions == 0 and not stranded
    claimed_reason = rec.stop_reason or (final.reason if final is not None else "no mission status was ever seen")
    goal = _goal_point(rec, len(rec.destinations) - 1)
    goal_error = None
    if goal is not None and len(truth):
        goal_error = round(float(_distance_to(truth[-1:], goal)[0]), 3)
    # the mission's span by the CAPTAIN's clock, which also stamps the steps; RTF over what the launcher saw
    if final is not None and final.submitted_at is not None and final.finished_at is not None:
        sim_span = final.finished_at - final.submitted_at
    else:
        sim_span = t1 - t0
    wall_span = rec.ended_wall_s - rec.submitted_wall_s
    pe = position_errors(est[:, 0], est[:, 1:3], truth_all[:, 0], truth_all[:, 1:3]) if len(est) else np.zeros(0)
    return RunReport(
        architecture=rec.architecture,
        success=success,
        claimed_success=claimed,
        reason="" if success and claimed else _disagreement(claimed, claimed_reason, steps, collisions, stranded),
        mission=rec.mission.name,
        world=rec.world,
        vehicle=rec.vehicle,
        seed=rec.seed,
        perception=rec.perception,
        pose_error=rec.pose_error,
        map_error=rec.map_error,
        sim_time_s=round(sim_span, 3),
        wall_time_s=round(wall_span, 3),
        rtf_requested=rec.rtf_requested,
        time_mode=rec.time_mode,
        rtf_achieved=round((t1 - t0) / wall_span, 3) if wall_span > 0 else 0.0,
        distance_m=round(path_length(truth[:, 1:3]), 3),
        steps=steps,
        goal_error_m=goal_error,
        cross_track_error_m=ErrorSummary.of(np.concatenate(ctes)),
        cross_track_error_newest_m=ErrorSummary.of(np.concatenate(ctes_newest)),
        replans=sum(s.replans for s in steps),
        position_error_m=ErrorSummary.of(pe),
        collisions=collisions,
        off_path_s=round(_off_path_s(rec.events, t0, settled), 3),
        sim_events=dict(Counter(e.kind for e in events)),
        blackboard=_bb_usage(rec.blackboard),
        modules=_module_costs(rec),
        exit_codes=dict(rec.exit_codes),
        stops=stop_summary(truth, actors=rec.actors, world_name=rec.world_file or rec.world, vehicle=rec.vehicle, t0=rec.submitted_sim_s),
        triggers=[t.model_copy(update={"sim_s": round(t.sim_s - t0, 3)}) for t in rec.triggers],
        faults=list(rec.faults),
        max_speed=rec.max_speed,
        mean_speed_m_s=round(path_length(truth[:, 1:3]) / sim_span, 3) if sim_span > 0 else None,
        restarts=list(rec.restarts),
        wedges=list(rec.wedges),
        gave_up=list(rec.gave_up),
    )


#: Fill colours for world object kinds on the trajectory plot.
KIND_COLOURS = {
    "road": "#9a9a9a",
    "sidewalk": "#c8c8c8",
    "intersection": "#b8b8b8",
    "driveway": "#b0a898",
    "grass": "#b5d99c",
    "slope": "#a8a8c8",
    "stairs": "#8c8ca8",
    "building": "#8b6f5a",
    "tree": "#3d7a35",
    "mailbox": "#2455a4",
}


def write_report(report: RunReport, out_dir: Path) -> Path:
    """Write `report.json` into out_dir and return its path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "report.json"
    path.write_text(dumps(report.model_dump(mode="json"), indent=2, sort_keys=False) + "\n")
    return path


def plot_trajectory(
    path: Path,
    *,
    objects: Sequence[tuple[str, np.ndarray]],
    route: Optional[np.ndarray],
    truth: Optional[np.ndarray],
    estimate: Optional[np.ndarray],
    title: str,
    margin_m: float = 20.0,
) -> Path:
    """Draw the map, planned route, true and estimated paths (all `world` [m]) into a PNG.

    The view spans the route and both paths plus `margin_m` [m].
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon as MplPolygon

    fig, ax = plt.subplots(figsize=(9, 9), dpi=110)
    order = {"grass": 0, "road": 1, "driveway": 1, "sidewalk": 2, "intersection": 2, "slope": 3, "stairs": 3}
    for kind, coords in sorted(objects, key=lambda o: order.get(o[0], 5)):
        coords = np.asarray(coords, dtype=float)
        colour = KIND_COLOURS.get(kind, "#d0d0d0")
        if coords.ndim == 2 and len(coords) >= 3:
            ax.add_patch(MplPolygon(coords, closed=True, facecolor=colour, edgecolor="#666666", lw=0.3))
        elif coords.size >= 2:
            c = coords.reshape(-1)[:2]
            ax.plot(c[0], c[1], "o", color=colour, ms=4)
    if route is not None and len(route) >= 2:
        ax.plot(route[:, 0], route[:, 1], "--", color="#e08a00", lw=1.5, label="planned route")
    if truth is not None and len(truth) >= 2:
        ax.plot(truth[:, 0], truth[:, 1], "-", color="#c01818", lw=1.6, label="true path")
        ax.plot(truth[0, 0], truth[0, 1], "s", color="#c01818", ms=6)
    if estimate is not None and len(estimate) >= 2:
        ax.plot(estimate[:, 0], estimate[:, 1], "-", color="#1840c0", lw=1.0, label="estimated path")
    ax.set_aspect("equal")
    ax.autoscale_view()
    shown = [a for a in (route, truth, estimate) if a is not None and len(a)]
    if shown:
        pts = np.concatenate([np.asarray(a, dtype=float)[:, :2] for a in shown])
        (x0, y0), (x1, y1) = pts.min(axis=0) - margin_m, pts.max(axis=0) + margin_m
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
    ax.set_xlabel("x [m] (world)")
    ax.set_ylabel("y [m] (world)")
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
