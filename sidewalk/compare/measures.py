"""The figures of one run that the comparison summarises, read from its report and its recording."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

from pydantic import BaseModel, ConfigDict, ValidationError

from sidewalk.compare.errors import CompareError
from sidewalk.compare.latency import Latencies, read_latencies
from sidewalk.report import RunReport

__all__ = ["RunMeasures", "measure_run", "load_report", "MEASURES"]

#: The summarised measures: field → (table group, label with unit).
MEASURES: dict[str, tuple[str, str]] = {
    "success": ("outcome", "success by truth"),
    "claimed_success": ("outcome", "claimed success"),
    "goal_error_m": ("outcome", "goal error [m]"),
    "collisions": ("outcome", "collisions"),
    "off_path_s": ("outcome", "time off path [s]"),
    "mission_time_s": ("outcome", "mission time [s sim]"),
    "mean_speed_m_s": ("outcome", "mean speed [m/s]"),
    "position_error_rms_m": ("accuracy", "position error rms [m]"),
    "position_error_max_m": ("accuracy", "position error max [m]"),
    "cross_track_error_rms_m": ("accuracy", "cross-track error rms [m]"),
    "cross_track_error_max_m": ("accuracy", "cross-track error max [m]"),
    "sense_to_act_ms_p50": ("reaction", "sense-to-act p50 [ms sim]"),
    "sense_to_act_ms_p95": ("reaction", "sense-to-act p95 [ms sim]"),
    "driving_unit_ms_p50": ("reaction", "driving unit → perception p50 [ms sim]"),
    "driving_unit_ms_p95": ("reaction", "driving unit → perception p95 [ms sim]"),
    "messages_per_s": ("cost", "messages out per s sim (all processes, without the lock-step barrier's)"),
    "bytes_per_s": ("cost", "bytes out per s sim (all processes, without the lock-step barrier's)"),
    "barrier_messages_per_s": ("cost", "lock-step barrier's messages out per s sim (the run mode's cost; 0 in real time)"),
    "cpu_s": ("cost", "CPU [s] (all processes)"),
    "cpu_s_modules": ("cost", "CPU [s] (modules, central piece, no sim/observers)"),
    "rss_mb": ("cost", "resident memory [MB] (sum of processes)"),
    "wall_time_s": ("cost", "wall time [s]"),
}

#: Processes that are the bench, not the architecture: left out of `cpu_s_modules`.
OBSERVERS = ("sim", "router", "recorder", "monitor")


class RunMeasures(BaseModel):
    """One run's figures (None: not measured in this run); `modules` holds per-process cost from the report."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    mission: str
    seed: int
    success: float
    claimed_success: float
    goal_error_m: Optional[float] = None
    collisions: float
    off_path_s: float
    mission_time_s: float
    mean_speed_m_s: Optional[float] = None
    position_error_rms_m: Optional[float] = None
    position_error_max_m: Optional[float] = None
    cross_track_error_rms_m: Optional[float] = None
    cross_track_error_max_m: Optional[float] = None
    sense_to_act_ms_p50: Optional[float] = None
    sense_to_act_ms_p95: Optional[float] = None
    driving_unit_ms_p50: Optional[float] = None
    driving_unit_ms_p95: Optional[float] = None
    messages_per_s: float
    bytes_per_s: float
    barrier_messages_per_s: float = 0.0
    cpu_s: float
    cpu_s_modules: float
    rss_mb: float
    wall_time_s: float


def load_report(path: Path) -> RunReport:
    """Read a `report.json`; raise CompareError naming the file."""
    try:
        return RunReport.model_validate(json.loads(Path(path).read_text()))
    except (OSError, ValueError) as exc:
        msg = exc.errors()[0]["msg"] if isinstance(exc, ValidationError) else str(exc)
        raise CompareError(f"{path}: not a run report: {msg}") from None


def measure_run(report: RunReport, latencies: Latencies | None = None) -> RunMeasures:
    """Return the run's figures from its report and (when recorded) its latencies."""
    span = report.sim_time_s if report.sim_time_s > 0 else float("nan")
    mods = report.modules
    lat = latencies
    s2a = lat.sense_to_act if lat is not None else None
    return RunMeasures(
        architecture=report.architecture, mission=report.mission, seed=report.seed,
        success=float(report.success), claimed_success=float(report.claimed_success),
        goal_error_m=report.goal_error_m, collisions=float(report.collisions), off_path_s=report.off_path_s,
        mission_time_s=report.sim_time_s,
        mean_speed_m_s=report.mean_speed_m_s if report.mean_speed_m_s is not None else (
            round(report.distance_m / report.sim_time_s, 3) if report.sim_time_s > 0 else None),
        position_error_rms_m=report.position_error_m.rms, position_error_max_m=report.position_error_m.max,
        cross_track_error_rms_m=report.cross_track_error_m.rms, cross_track_error_max_m=report.cross_track_error_m.max,
        sense_to_act_ms_p50=s2a.p50_ms if s2a else None, sense_to_act_ms_p95=s2a.p95_ms if s2a else None,
        driving_unit_ms_p50=lat.driving_unit.p50_ms if lat else None, driving_unit_ms_p95=lat.driving_unit.p95_ms if lat else None,
        messages_per_s=round(sum(m.msgs_out - m.barrier_msgs_out for m in mods.values()) / span, 2),
        bytes_per_s=round(sum(m.bytes_out - m.barrier_bytes_out for m in mods.values()) / span, 1),
        barrier_messages_per_s=round(sum(m.barrier_msgs_out for m in mods.values()) / span, 2),
        cpu_s=round(sum(m.cpu_s for m in mods.values()), 3),
        cpu_s_modules=round(sum(m.cpu_s for n, m in mods.items() if n not in OBSERVERS), 3),
        rss_mb=round(sum(m.rss_mb for m in mods.values()), 1),
        wall_time_s=report.wall_time_s,
    )


def measure_dir(run_dir: Path) -> tuple[RunReport, RunMeasures]:
    """Return the report and figures of a run directory (report.json, run.mcap if present)."""
    report = load_report(Path(run_dir) / "report.json")
    mcap = Path(run_dir) / "run.mcap"
    return report, measure_run(report, read_latencies(mcap) if mcap.exists() else None)


__all__ += ["measure_dir", "OBSERVERS"]
