"""Reaction latencies read from a run's recording (`run.mcap`), by the recorder's sim clock.

Every message of a recording is logged at the sim time [s] the recorder heard it. Sense-to-act:
for each capture stamp `sensed_at` [s sim] the drive commands on the simulator's drive key carry,
the first command carrying it minus the capture — the time from a camera frame to the first drive
command built on it. Driving-unit latency (CODGER): a driving unit's token stamp to the stamp of
PERCEPTION's result for it. Both are sim seconds; divided by the run's achieved real-time factor
they are the wall time the modules took.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
from pydantic import BaseModel, ConfigDict

from sidewalk.compare.errors import CompareError
from sidewalk.recording.errors import RecordingError
from sidewalk.recording.reader import open_recording
from wire.summary import percentiles

__all__ = ["LatencySeries", "Latencies", "read_latencies", "sense_to_act_s", "unit_latency_s"]


class LatencySeries(BaseModel):
    """A latency series summarised [ms, sim clock]: p50, p95, max; n samples (None figures: none)."""

    model_config = ConfigDict(frozen=True)

    p50_ms: Optional[float] = None
    p95_ms: Optional[float] = None
    max_ms: Optional[float] = None
    n: int = 0

    @classmethod
    def of(cls, seconds: np.ndarray) -> "LatencySeries":
        """Summarise latencies (N,) [s]."""
        s = np.asarray(seconds, dtype=float)
        if s.size == 0:
            return cls()
        ms = s * 1000.0
        p50, p95 = percentiles(ms, (50, 95), digits=1)
        return cls(p50_ms=p50, p95_ms=p95,
                   max_ms=round(float(ms.max()), 1), n=int(ms.size))


class Latencies(BaseModel):
    """The reaction latencies of one run (sim clock)."""

    model_config = ConfigDict(frozen=True)

    sense_to_act: LatencySeries
    driving_unit: LatencySeries


def sense_to_act_s(commands: list[tuple[float, Optional[float]]]) -> np.ndarray:
    """Return, per capture, the first command's log time minus the capture [s]: commands are (log [s], sensed_at [s] or None)."""
    first: dict[float, float] = {}
    for logged, sensed in commands:
        if sensed is not None and sensed not in first:
            first[sensed] = logged
    return np.array([first[s] - s for s in sorted(first)], dtype=float)


def unit_latency_s(units: list[tuple[str, float]], results: list[tuple[str, float]]) -> np.ndarray:
    """Return, per unit answered, result stamp minus the unit's first stamp [s]: both lists are (unit id, stamp [s])."""
    posted: dict[str, float] = {}
    for uid, t in units:
        posted.setdefault(uid, t)
    answered: dict[str, float] = {}
    for uid, t in results:
        if uid in posted and uid not in answered:
            answered[uid] = t - posted[uid]
    return np.array(list(answered.values()), dtype=float)


def read_latencies(path: Path) -> Latencies:
    """Read a run's recording and return its latencies; raise CompareError if it cannot be read."""
    cmds: list[tuple[float, Optional[float]]] = []
    units: list[tuple[str, float]] = []
    results: list[tuple[str, float]] = []
    try:
        for m in open_recording(Path(path)).messages(["/sim/cmd", "/tokens/driving_unit", "/tokens/perception_result"]):
            if m.topic == "/sim/cmd":
                cmds.append((m.log_time, m.value.get("sensed_at")))
                continue
            tok = m.value.get("token") or {}
            attrs = tok.get("attrs") or {}
            if m.value.get("event") != "new" or "unit_id" not in attrs:
                continue
            (units if m.topic == "/tokens/driving_unit" else results).append((attrs["unit_id"], float(tok.get("stamp", m.log_time))))
    except (RecordingError, OSError) as exc:
        raise CompareError(f"{path}: cannot read the recording: {exc}") from None
    return Latencies(sense_to_act=LatencySeries.of(sense_to_act_s(cmds)), driving_unit=LatencySeries.of(unit_latency_s(units, results)))
