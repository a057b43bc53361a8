"""The comparison grid: every mission × seed × architecture (and fault, and speed) as a `sidewalk run` subprocess.

Each run is its own `python -m sidewalk run` with the same seed for every architecture, so the
world, the map error, the pose error and the simulator's sensor and odometry noise are the same
(the simulator and the PILOT take `--seed`; the map and pose errors are drawn from it). A run's
output directory is `<out>/runs/<arch>/<mission>/seed<S>[-<fault>|-v<speed>]`.
"""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
from pathlib import Path
from typing import Callable, Optional, Protocol, Sequence

from pydantic import BaseModel, ConfigDict

from sidewalk.compare.faults import FaultSpec
from wire.lifeline import die_with_parent

__all__ = ["GridRun", "GridResult", "CellRunner", "available_architectures", "run_grid", "ARCHITECTURES"]

#: Every architecture the comparison knows, in table order.
ARCHITECTURES = ("codger", "eddie")


class GridRun(BaseModel):
    """One cell of the grid: what `sidewalk run` is asked to do, and where it writes."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    mission: str
    world: Optional[str] = None
    seed: int
    rtf: float
    out: Path
    fault: Optional[FaultSpec] = None
    max_speed: Optional[float] = None
    max_wall_time_s: float = 900.0
    max_sim_time_s: Optional[float] = None
    #: run in lock-step (`sidewalk run --lockstep`) rather than in real time at `rtf`
    lockstep: bool = False
    #: an actors file (`sidewalk run --actors`) and how the road is found (`--road-method`; None: the run's default)
    actors: Optional[str] = None
    road_method: Optional[str] = None

    @property
    def label(self) -> str:
        """Return a short name for the progress bar."""
        extra = f" {self.fault.name}" if self.fault else (f" v≤{self.max_speed:g}" if self.max_speed else "")
        return f"{self.architecture} {Path(self.mission).stem} s{self.seed}{extra}{' +actors' if self.actors else ''}"

    def argv(self, *, arch_flag: bool) -> list[str]:
        """Return the command line (after the interpreter); `arch_flag`: the run command takes --arch."""
        args = ["-m", "sidewalk", "run", "--mission", self.mission, "--seed", str(self.seed), "--rtf", f"{self.rtf:g}",
                "--out", str(self.out), "--max-wall-time", f"{self.max_wall_time_s:g}"]
        if self.max_sim_time_s is not None:
            args += ["--max-sim-time", f"{self.max_sim_time_s:g}"]
        if self.world:
            args += ["--world", self.world]
        if arch_flag:
            args += ["--arch", self.architecture]
        if self.fault is not None:
            args += ["--fault", self.fault.flag()]
        if self.max_speed is not None:
            args += ["--max-speed", f"{self.max_speed:g}"]
        if self.lockstep:
            args += ["--lockstep"]
        if self.actors is not None:
            args += ["--actors", self.actors]
        if self.road_method is not None:
            args += ["--road-method", self.road_method]
        return args


class GridResult(BaseModel):
    """A finished run: its cell, the exit code (0 success, 1 mission failed, other: did not run) and whether it wrote a report."""

    model_config = ConfigDict(frozen=True)

    run: GridRun
    exit_code: int
    has_report: bool


class CellRunner(Protocol):
    """What runs a cell elsewhere (`sidewalk.compare.cluster.ClusterSession`): its run directory lands in `run.out`."""

    async def run(self, run: GridRun, *, arch_flag: bool) -> int:
        """Run the cell; return its exit code."""
        ...


def available_architectures(python: str = sys.executable) -> tuple[list[str], bool]:
    """Ask `sidewalk run --help` which architectures it runs; return them and whether it takes --arch."""
    text = subprocess.run([python, "-m", "sidewalk", "run", "--help"], capture_output=True, text=True,
                          env={"COLUMNS": "200", **__import__("os").environ}).stdout
    if "--arch" not in text:
        return ["codger"], False
    return [a for a in ARCHITECTURES if a in text] or ["codger"], True


def _finished(run: GridRun) -> Optional[int]:
    """Return the exit code of a finished run of this very cell in its directory (None: there is none)."""
    try:
        rep = json.loads((run.out / "report.json").read_text())
    except (OSError, ValueError):
        return None
    same = (rep.get("architecture") == run.architecture and rep.get("mission") == Path(run.mission).stem
            and rep.get("seed") == run.seed and rep.get("max_speed") == run.max_speed
            and rep.get("time_mode", "realtime") == ("lockstep" if run.lockstep else "realtime")
            and [f.get("name") for f in rep.get("faults", [])] == ([run.fault.name] if run.fault else []))
    return (0 if rep.get("success") else 1) if same else None


async def _one(run: GridRun, python: str, arch_flag: bool, resume: bool, cluster: Optional["CellRunner"]) -> GridResult:
    run.out.mkdir(parents=True, exist_ok=True)
    if resume and (code := _finished(run)) is not None:
        return GridResult(run=run, exit_code=code, has_report=True)
    (run.out / "report.json").unlink(missing_ok=True)  # a report left by an earlier comparison is not this run's
    if cluster is not None:
        code = await cluster.run(run, arch_flag=arch_flag)
        return GridResult(run=run, exit_code=code, has_report=(run.out / "report.json").exists())
    with open(run.out / "compare-run.log", "wb") as log:
        proc = await asyncio.create_subprocess_exec(python, *run.argv(arch_flag=arch_flag), stdin=asyncio.subprocess.DEVNULL,
                                                    stdout=log, stderr=log, preexec_fn=die_with_parent())
        code = await proc.wait()
    return GridResult(run=run, exit_code=code, has_report=(run.out / "report.json").exists())


async def run_grid(runs: Sequence[GridRun], *, jobs: int = 1, arch_flag: bool = False, python: str = sys.executable,
                   resume: bool = False, cluster: Optional["CellRunner"] = None,
                   on_start: Callable[[GridRun], None] | None = None,
                   on_done: Callable[[GridResult], None] | None = None) -> list[GridResult]:
    """Run the cells, at most `jobs` at a time (`resume`: reuse a finished run of the same command); return their results in order.

    With a `cluster` every cell is sent at once and its scheduler decides how many run (one per worker); `jobs` is unused.
    """
    gate = asyncio.Semaphore(len(runs) if cluster is not None else max(1, jobs))

    async def guarded(r: GridRun) -> GridResult:
        async with gate:
            if on_start:
                on_start(r)
            res = await _one(r, python, arch_flag, resume, cluster)
            if on_done:
                on_done(res)
            return res

    return list(await asyncio.gather(*(guarded(r) for r in runs)))
