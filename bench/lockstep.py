"""Lock-step speed: the real-time factor a grid's lock-step runs reach, per architecture and mission.

Each cell is one `sidewalk run --lockstep` (recorded, as `sidewalk compare` runs it) of a shipped
mission at one seed. Per run, from its `report.json`:

- `lockstep_rtf`: sim time over wall time of the mission (the report's `rtf_achieved`);
- `cpu_s` [s]: every process's CPU, and `cpu_per_sim_s` [s/s sim];
- `msgs_per_sim_s` / `bytes_per_sim_s`: messages and payload bytes sent per sim second, the modules'
  traffic only, and `barrier_msgs_per_sim_s` apart: what lock-step itself costs (`sidewalk compare`'s own
  figures, `sidewalk.compare.measures`);
- `barrier_waves` and `waves_per_barrier`: the barrier's waves (`wire.lockstep`), from the figures the
  simulator prints at exit (`BarrierStats`, in `logs/sim.log`), over its barriers (two per published
  tick); `barrier_asks` the ask puts (one per wave to everyone, one per participant a wave asks alone),
  and of the barriers, `quiet_by_channels` (one wave and the channel counts) and `targeted_waves`;
- the verdict (`success`, `goal_error_m`), so a faster run that decides otherwise shows.

`lockstep_rtf` (top level) is {architecture: {mission: rtf}}; `loadavg_1m` says how busy the machine was
(a lock-step run's decisions do not depend on load, its wall time does).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.errors import BenchError
from sidewalk.compare.measures import measure_dir
from vehicle_sim.node import BARRIER_LINE

__all__ = ["run", "DEFAULT_MISSIONS"]

#: The comparison's default missions.
DEFAULT_MISSIONS = ("campus-tour", "amv-delivery")


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
    asks = sim.barrier_msgs_out if sim is not None else 0
    stats = _barrier_stats(out / "logs" / "sim.log")
    return {
        "mission": mission, "arch": arch, "seed": seed, "success": report.success, "reason": report.reason,
        "goal_error_m": report.goal_error_m, "sim_time_s": report.sim_time_s, "wall_time_s": report.wall_time_s,
        "command_wall_s": round(wall, 1), "lockstep_rtf": report.rtf_achieved,
        "cpu_s": round(m.cpu_s, 1), "cpu_per_sim_s": round(m.cpu_s / sim_s, 3),
        "msgs_per_sim_s": m.messages_per_s, "bytes_per_sim_s": round(m.bytes_per_s),
        "barrier_msgs_per_sim_s": m.barrier_messages_per_s, "barrier_asks": asks,
        "barrier_waves": stats.get("waves"), "barriers": stats.get("steps"),
        "waves_per_barrier": round(stats["waves"] / stats["steps"], 3) if stats.get("steps") else None,
        "quiet_by_channels": stats.get("by_channels"), "targeted_waves": stats.get("targeted_waves"),
        "channel_fallbacks": stats.get("channel_fallbacks"), "run": str(out),
    }


def _barrier_stats(log: Path) -> dict:
    """Return the barrier's figures the simulator printed at exit ({} when its log has none)."""
    try:
        lines = log.read_text(errors="replace").splitlines()
    except OSError:
        return {}
    for line in reversed(lines):
        if line.startswith(BARRIER_LINE):
            try:
                return json.loads(line[len(BARRIER_LINE):])
            except ValueError:
                return {}
    return {}


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
