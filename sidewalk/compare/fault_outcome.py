"""What a fault did to a run: completed, degraded (how) or failed (why), and the recovery time.

Judged against the same mission's runs without a fault (the baseline, medians over seeds):
- failed: the run failed by truth (the report's reason);
- degraded: it succeeded, but took more than `SLOWER` × the baseline's mission time, or its position
  error peaked more than `WORSE_M` [m] above the baseline's peak, or it collided or left the path longer;
- completed: none of these.
Recovery time [s sim]: from the injection until the vehicle had driven at ≥ half its speed of the
`BEFORE_S` [s] before the fault for `HELD_S` [s] without a break, and its position error was back
under max(1 m, twice the error at the injection). None: it never recovered within the record.
"""

from __future__ import annotations

from typing import Literal, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict

from sidewalk.compare.measures import RunMeasures
from sidewalk.metrics import position_errors
from sidewalk.report import RunReport
from sidewalk.run_record import RunRecord

__all__ = ["FaultOutcome", "judge_fault", "recovery_s", "SLOWER", "WORSE_M", "BEFORE_S", "HELD_S"]

SLOWER = 1.25
WORSE_M = 1.0
BEFORE_S = 10.0
HELD_S = 1.0


class FaultOutcome(BaseModel):
    """One fault run's verdict."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    mission: str
    seed: int
    fault: str
    injected: bool
    verdict: Literal["completed", "degraded", "failed", "not injected"]
    how: str = ""
    at_s: Optional[float] = None  # [s sim] after submission
    recovery_s: Optional[float] = None
    mission_time_s: Optional[float] = None
    position_error_max_m: Optional[float] = None


def _speeds(truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (t, speed) [s, m/s] of a truth track (N,4), speeds from successive rows."""
    if len(truth) < 2:
        return np.zeros(0), np.zeros(0)
    dt = np.diff(truth[:, 0])
    ds = np.hypot(np.diff(truth[:, 1]), np.diff(truth[:, 2]))
    ok = dt > 1e-9
    return truth[1:, 0][ok], ds[ok] / dt[ok]


def recovery_s(rec: RunRecord, at: float) -> Optional[float]:
    """Return the recovery time [s sim] after a fault injected at `at` [s sim, recorder clock] (see the module)."""
    truth = np.asarray(rec.truth, dtype=float).reshape(-1, 4)
    est = np.asarray(rec.estimate, dtype=float).reshape(-1, 4)
    t, v = _speeds(truth)
    before = v[(t >= at - BEFORE_S) & (t < at)]
    if before.size == 0:
        return None
    v_ok = 0.5 * float(np.mean(before))
    if len(est) and len(truth) >= 2:
        est = est[(est[:, 0] >= truth[0, 0]) & (est[:, 0] <= truth[-1, 0])]
    err_t = est[:, 0]
    err = position_errors(est[:, 0], est[:, 1:3], truth[:, 0], truth[:, 1:3]) if len(est) else np.zeros(0)
    e0 = float(np.interp(at, err_t, err)) if len(err) else 0.0
    e_ok = max(1.0, 2.0 * e0)
    after = t >= at
    held_since: Optional[float] = None
    for ti, vi in zip(t[after], v[after]):
        err_now = float(np.interp(ti, err_t, err)) if len(err) else 0.0
        if vi >= v_ok and err_now <= e_ok:
            held_since = ti if held_since is None else held_since
            if ti - held_since >= HELD_S:
                return round(held_since - at, 2)
        else:
            held_since = None
    return None


def judge_fault(report: RunReport, rec: RunRecord, measures: RunMeasures, baseline: list[RunMeasures]) -> FaultOutcome:
    """Judge a fault run against the baseline runs of the same mission and architecture."""
    ev = report.faults[0] if report.faults else None
    common = dict(architecture=report.architecture, mission=report.mission, seed=report.seed,
                  fault=ev.name if ev else "?", mission_time_s=report.sim_time_s,
                  position_error_max_m=report.position_error_m.max)
    if ev is None or not ev.injected:
        return FaultOutcome(injected=False, verdict="not injected", how=ev.detail if ev else "no fault was recorded", **common)
    at_rel = round(ev.at_sim_s - rec.submitted_sim_s, 2)
    rec_s = recovery_s(rec, ev.at_sim_s)
    if not report.success:
        return FaultOutcome(injected=True, verdict="failed", how=report.reason or "failed by truth", at_s=at_rel,
                            recovery_s=rec_s, **common)
    how = []
    if baseline:
        t_base = float(np.median([b.mission_time_s for b in baseline]))
        if report.sim_time_s > SLOWER * t_base:
            how.append(f"mission {report.sim_time_s:.0f} s against {t_base:.0f} s without the fault")
        peaks = [b.position_error_max_m for b in baseline if b.position_error_max_m is not None]
        pe = report.position_error_m.max
        if peaks and pe is not None and pe > max(peaks) + WORSE_M:
            how.append(f"position error peaked at {pe:.2f} m (baseline ≤ {max(peaks):.2f} m)")
        off = max(b.off_path_s for b in baseline)
        if report.off_path_s > off + 1.0:
            how.append(f"{report.off_path_s:.1f} s off the path (baseline ≤ {off:.1f} s)")
    if report.collisions:
        how.append(f"{report.collisions} collision(s)")
    return FaultOutcome(injected=True, verdict="degraded" if how else "completed", how="; ".join(how), at_s=at_rel,
                        recovery_s=rec_s, **common)
