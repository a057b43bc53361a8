"""Lock-step speed: the real-time factor a grid's lock-step runs reach, per architecture and mission.

Each cell is one `sidewalk run --lockstep` (recorded, as `sidewalk compare` runs it) of a shipped
mission at one seed. Per run, from its `report.json`:

- `lockstep_rtf`: sim time over wall time of the mission (the report's `rtf_achieved`);
- `cpu_s` [s]: every process's CPU, and `cpu_per_sim_s` [s/s sim];
- `msgs_per_sim_s` / `bytes_per_sim_s`: messages and payload bytes sent per sim second, the modules'
  traffic only, and `barrier_msgs_per_sim_s` apart: what lock-step itself costs (`sidewalk compare`'s own
  figures, `sidewalk.compare.measures`);
- `barrier_waves`: the barrier's asks (one put per wave, `wire.lockstep`), and `waves_per_barrier`
  over the two barriers of each published tick (`publish_hz` ticks per sim second);
- the verdict (`success`, `goal_error_m`), so a faster run that decides otherwise shows.

`lockstep_rtf` (top level) is {architecture: {mission: rtf}}; `loadavg_1m` says how busy the machine was
(a lock-step run's decisions do not depend on load, its wall time does).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.errors import BenchError
from sidewalk.compare.measures import measure_dir
from vehicle_sim.node import NodeConfig

__all__ = ["run", "DEFAULT_MISSIONS", "PUBLISH_HZ"]

#: The comparison's default missions.
DEFAULT_MISSIONS = ("campus-tour", "amv-delivery")
#: The simulator's clock publications per sim second (its default): two barriers each.
PUBLISH_HZ = NodeConfig.model_fields["publish_hz"].default


def _one(mission: str, arch: str, seed: int, out: Path, max_wall_s: float) -> dict:
    cmd = [sys.executable, "-m", "sidewalk", "run", "--mission", mission, "--arch", arch, "--seed", str(seed),
           "--lockstep", "--out", str(out), "--max-wall-time", f"{max_wall_s:g}"]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    if not (out / "report.json").exists():
        raise BenchError(f"{arch} {mission} seed {seed}: no report (exit {p.returncode}): {p.stderr.strip()[-400:]}")
    report, m = measure_dir(out)  # the comparison's own figures of the run
    sim_s = report.sim_time_s or 1e-9
    sim = report.modules.get("sim")
    waves = sim.barrier_msgs_out if sim is not None else 0
    return {
        "mission": mission, "arch": arch, "seed": seed, "success": report.success, "reason": report.reason,
        "goal_error_m": report.goal_error_m, "sim_time_s": report.sim_time_s, "wall_time_s": report.wall_time_s,
        "command_wall_s": round(wall, 1), "lockstep_rtf": report.rtf_achieved,
        "cpu_s": round(m.cpu_s, 1), "cpu_per_sim_s": round(m.cpu_s / sim_s, 3),
        "msgs_per_sim_s": m.messages_per_s, "bytes_per_sim_s": round(m.bytes_per_s),
        "barrier_msgs_per_sim_s": m.barrier_messages_per_s, "barrier_waves": waves,
        "waves_per_barrier": round(waves / (2 * PUBLISH_HZ * sim_s), 3), "run": str(out),
    }


def run(missions: tuple[str, ...] = DEFAULT_MISSIONS, archs: tuple[str, ...] = ("codger", "eddie"), seed: int = 0,
        out: Path | None = None, max_wall_s: float = 1800.0) -> dict:
    """Run every mission × architecture once in lock-step at `seed`; return the figures (see the module docstring)."""
    base = Path(out) if out is not None else Path(tempfile.mkdtemp(prefix="bench-lockstep-"))
    load0 = os.getloadavg()[0]
    runs = [_one(m, a, seed, base / f"{a}-{Path(m).stem}-s{seed}", max_wall_s) for a in archs for m in missions]
    rtf: dict[str, dict[str, float]] = {}
    for r in runs:
        rtf.setdefault(r["arch"], {})[Path(r["mission"]).stem] = r["lockstep_rtf"]
    return {"lockstep_rtf": rtf, "runs": runs, "seed": seed, "out": str(base),
            "loadavg_1m": round(max(load0, os.getloadavg()[0]), 2), "cpus": os.cpu_count()}
