"""Summary statistics over seeds: per architecture (and mission), each measure's median and range.

The spread reported is the range (min, max) over the runs, with the median as the central figure;
with 3 seeds a bootstrap interval would only restate the range. `success_rate` is the mean of the
truth verdicts over every run, a run that wrote no report (`Unreported`) counting as a failure; such
a run has no other figure. Missing figures (None) are left out of a measure's statistics and counted in `n`.
"""

from __future__ import annotations

import math
from typing import Iterable, Optional, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

from sidewalk.compare.measures import MEASURES, RunMeasures

__all__ = ["Spread", "ArchSummary", "Unreported", "spread", "summarise", "within_spread"]


class Spread(BaseModel):
    """A measure over runs: median, min, max over the n runs that have it (None: no run has it)."""

    model_config = ConfigDict(frozen=True)

    median: Optional[float] = None
    min: Optional[float] = None
    max: Optional[float] = None
    n: int = 0


def spread(values: Iterable[Optional[float]]) -> Spread:
    """Return median and range of the finite values."""
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return Spread()
    return Spread(median=round(float(np.median(v)), 4), min=round(float(v.min()), 4), max=round(float(v.max()), 4), n=int(v.size))


class Unreported(BaseModel):
    """A run that wrote no report (it would not start, crashed, or was stopped): a failed run, and why."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    mission: str
    seed: int
    reason: str


class ArchSummary(BaseModel):
    """One architecture's figures over a set of runs; the headline fields are the medians."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    mission: str  # "*" for every mission together
    runs: int
    success_rate: float
    #: of `runs`, how many wrote no report (each a failure in `success_rate` and the `success` measure)
    unreported: int = 0
    sense_to_act_ms_p50: Optional[float] = None
    messages_per_s: Optional[float] = None
    cpu_s: Optional[float] = None
    position_error_rms_m: Optional[float] = None
    measures: dict[str, Spread]


def summarise(runs: Sequence[RunMeasures | Unreported], mission: str = "*") -> list[ArchSummary]:
    """Summarise runs per architecture (in first-seen order) over `mission` ("*": all); a run without a report failed."""
    archs = list(dict.fromkeys(r.architecture for r in runs))
    out = []
    for a in archs:
        mine = [r for r in runs if r.architecture == a and (mission == "*" or r.mission == mission)]
        if not mine:
            continue
        reported = [r for r in mine if isinstance(r, RunMeasures)]
        m = {k: spread(getattr(r, k) for r in reported) for k in MEASURES}
        m["success"] = spread(r.success if isinstance(r, RunMeasures) else 0.0 for r in mine)
        out.append(ArchSummary(
            architecture=a, mission=mission, runs=len(mine), unreported=len(mine) - len(reported),
            success_rate=round(sum(r.success for r in reported) / len(mine), 4),
            sense_to_act_ms_p50=m["sense_to_act_ms_p50"].median, messages_per_s=m["messages_per_s"].median,
            cpu_s=m["cpu_s"].median, position_error_rms_m=m["position_error_rms_m"].median, measures=m,
        ))
    return out


def within_spread(a: Spread, b: Spread) -> bool:
    """Return whether each median lies within the other's range (both missing: True)."""
    if a.median is None or b.median is None:
        return a.median is None and b.median is None
    return bool(b.min <= a.median <= b.max and a.min <= b.median <= a.max)
