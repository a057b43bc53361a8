"""A whole comparison: the baseline grid, the fault runs, the speed sweep, the glue count — one `compare.json`.

Order: every mission × seed × architecture without a fault; then, with `with_actors`, every generated layout × seed ×
architecture with its actors file; then each fault once per mission ×
architecture on the first seed, injected at `FAULT_AT` × that mission's median baseline mission
time; then the speed sweep, speed by speed, each architecture until a speed where some seed fails.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Optional, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from sidewalk.compare.errors import CompareError
from sidewalk.compare.fault_outcome import FaultOutcome, judge_fault
from sidewalk.compare.faults import ROLES, TARGETS, FaultSpec
from sidewalk.compare.glue import GlueCount, count_glue
from sidewalk.compare.grid import GridResult, GridRun, run_grid
from sidewalk.compare.layouts import Layout, LayoutRow, LayoutTotal, layout_rows, layout_totals
from sidewalk.compare.measures import RunMeasures, measure_dir
from sidewalk.compare.summary import ArchSummary, Unreported, summarise
from sidewalk.run_record import RunRecordError, load_record

if TYPE_CHECKING:
    from sidewalk.compare.cluster import ClusterSession

__all__ = ["CompareConfig", "RunEntry", "SweepPoint", "Comparison", "run_comparison", "summaries", "FAULT_AT", "SOURCE_ROOT",
           "mission_world", "mission_name"]

#: Where in the mission a fault is injected: this fraction of the baseline's median mission time.
FAULT_AT = 0.4

#: A fault or sweep run gives up after this many times the baseline's wall and sim time (+ 60 s).
BUDGET = 2.5

#: The architectures whose `sidewalk run --max-speed` reaches the modules that set the speed (the sweep runs only these).
SPEED_CAPPED = ("codger", "eddie")

#: The source tree whose glue is counted.
SOURCE_ROOT = Path(__file__).resolve().parents[2]


class CompareConfig(BaseModel):
    """What `sidewalk compare` runs."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    missions: tuple[str, ...] = ("campus-tour", "amv-delivery")
    seeds: tuple[int, ...] = (0, 1, 2)
    rtf: float = Field(default=8.0, gt=0.0)
    architectures: tuple[str, ...] = ("codger",)
    faults: tuple[str, ...] = ()
    speeds: tuple[float, ...] = ()
    out: Path = Path("runs/compare")
    jobs: int = Field(default=1, ge=1)
    arch_flag: bool = False
    max_wall_time_s: float = Field(default=3600.0, gt=0.0)
    resume: bool = False
    #: every run in lock-step (reproducible; `rtf` unused) or, False, in real time at `rtf` (latency under load measured)
    lockstep: bool = True
    #: the Dask scheduler whose workers run the cells (`tcp://HOST:8786`; None: here, `jobs` at a time)
    cluster: Optional[str] = None
    #: generated layouts among `missions` (their world files), each run once more with its actors file when `with_actors`
    layouts: tuple[Layout, ...] = ()
    with_actors: bool = False
    #: `sidewalk run --road-method` of every run (None: the run's default)
    road_method: Optional[str] = None


class RunEntry(BaseModel):
    """One run of the comparison: what was asked, how it ended, its report and figures (None: no report)."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    mission: str
    seed: int
    fault: Optional[str] = None
    max_speed: Optional[float] = None
    #: the actors file the run had (None: none)
    actors: Optional[str] = None
    out: str
    exit_code: int
    report: Optional[dict] = None
    measures: Optional[RunMeasures] = None
    error: str = ""

    def outcome(self, mission: str) -> RunMeasures | Unreported:
        """Return the run's figures, or (no report, or one that cannot be read) a failed run named `mission` with its reason."""
        if self.measures is not None:
            return self.measures
        return Unreported(architecture=self.architecture, mission=mission, seed=self.seed, reason=self.error or "no report")


class SweepPoint(BaseModel):
    """The speed sweep at one speed cap [m/s] for one architecture: runs and successes by truth."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    max_speed: float
    runs: int
    successes: int
    mean_speed_m_s: Optional[float] = None
    mission_time_s: Optional[float] = None


class Comparison(BaseModel):
    """Everything `compare.json` holds."""

    model_config = ConfigDict(frozen=True)

    config: CompareConfig
    available: list[str]
    requested: list[str]
    runs: list[RunEntry]
    summary: dict[str, ArchSummary]
    per_mission: list[ArchSummary]
    faults: list[FaultOutcome] = []
    speed_sweep: list[SweepPoint] = []
    highest_speed: dict[str, Optional[float]] = {}
    glue: list[GlueCount] = []
    wall_time_s: float = 0.0
    #: how sim time advanced in every run: `lockstep` or `realtime`
    time_mode: str = "realtime"
    #: generated layouts: a row per layout × architecture (× with/without actors), and the totals per kind
    layouts: list[LayoutRow] = []
    layout_totals: list[LayoutTotal] = []


def _entry(res: GridResult) -> RunEntry:
    r = res.run
    base = dict(architecture=r.architecture, mission=r.mission, seed=r.seed, fault=r.fault.name if r.fault else None,
                max_speed=r.max_speed, actors=r.actors, out=str(r.out), exit_code=res.exit_code)
    if not res.has_report:
        log = r.out / "compare-run.log"
        tail = log.read_text(errors="replace").strip().splitlines()[-1:] if log.exists() else []
        return RunEntry(**base, error=f"no report (exit {res.exit_code}): {tail[0] if tail else ''}")
    try:
        report, m = measure_dir(r.out)
    except CompareError as exc:
        return RunEntry(**base, error=str(exc))
    return RunEntry(**base, report=report.model_dump(mode="json"), measures=m)


def mission_world(mission: str) -> Optional[str]:
    """Return the world a mission names (None: any); raise CompareError for an unknown mission."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from sidewalk.launcher import mission_path

    try:
        return load_mission(mission_path(mission)).world
    except (FileNotFoundError, MissionFileError) as exc:
        raise CompareError(f"--missions: {exc}") from None


def mission_name(mission: str) -> str:
    """Return the name a mission's reports carry (its file's `mission:`); raise CompareError for an unknown mission."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from sidewalk.launcher import mission_path

    try:
        return load_mission(mission_path(mission)).name
    except (FileNotFoundError, MissionFileError) as exc:
        raise CompareError(f"--missions: {exc}") from None


def summaries(entries: Sequence[RunEntry], missions: Sequence[str]) -> tuple[dict[str, ArchSummary], list[ArchSummary]]:
    """Return the summary per architecture and per mission × architecture of the baseline runs `entries`.

    Every run counts: one that wrote no report is a failed run (`Unreported`, with its reason).
    """
    names = {m: mission_name(m) for m in dict.fromkeys([*missions, *(e.mission for e in entries)])}
    runs = [e.outcome(names[e.mission]) for e in entries]
    return ({s.architecture: s for s in summarise(runs)},
            [s for m in missions for s in summarise(runs, mission=names[m])])


def _budgets(measured: Sequence[RunMeasures], arch: str, mission: str, cfg: CompareConfig) -> dict[str, float]:
    """Return the wall and sim budgets [s] of a fault or sweep run: a multiple of the baseline's (a stuck run gives up)."""
    mine = [m for m in measured if m.architecture == arch and m.mission == mission_name(mission)]
    if not mine:
        return {}
    wall = float(np.median([m.wall_time_s for m in mine]))
    sim = float(np.median([m.mission_time_s for m in mine]))
    return {"max_wall_time_s": min(cfg.max_wall_time_s, BUDGET * wall + 60.0), "max_sim_time_s": BUDGET * sim + 60.0}


def _cells(cfg: CompareConfig, archs: Sequence[str], seeds: Sequence[int], *, tag: str = "",
           fault: FaultSpec | None = None, speed: float | None = None, mission: str | None = None,
           measured: Sequence[RunMeasures] = (), missions: Sequence[str] | None = None, with_actors: bool = False) -> list[GridRun]:
    out = []
    generated = {lay.mission: lay for lay in cfg.layouts}
    for m in ([mission] if mission else (missions if missions is not None else cfg.missions)):
        lay = generated.get(m)
        for s in seeds:
            for a in archs:
                budget = {"max_wall_time_s": cfg.max_wall_time_s, **_budgets(measured, a, m, cfg)}
                out.append(GridRun(architecture=a, mission=m, world=lay.world if lay else mission_world(m), seed=s, rtf=cfg.rtf,
                                   fault=fault, lockstep=cfg.lockstep, max_speed=speed, road_method=cfg.road_method,
                                   actors=lay.actors if (lay and with_actors) else None,
                                   out=cfg.out / "runs" / a / mission_name(m) / f"seed{s}{tag}", **budget))
    return out


async def run_comparison(cfg: CompareConfig, available: list[str], *, total: Callable[[int], None] | None = None,
                         on_start: Callable[[GridRun], None] | None = None,
                         on_done: Callable[[GridResult], None] | None = None, python: str = sys.executable) -> Comparison:
    """Run the comparison (on `cfg.cluster`'s workers if set); `total(n)` announces more cells as the grid grows (faults and sweep come later)."""
    t0 = time.monotonic()
    if cfg.cluster is None:
        return await _run_comparison(cfg, available, total=total, on_start=on_start, on_done=on_done, python=python, t0=t0)
    from sidewalk.compare.cluster import connect

    session = await connect(cfg.cluster)
    try:
        return await _run_comparison(cfg, available, total=total, on_start=on_start, on_done=on_done, python=python, t0=t0,
                                     cluster=session)
    finally:
        await session.close()


async def _run_comparison(cfg: CompareConfig, available: list[str], *, total: Callable[[int], None] | None,
                          on_start: Callable[[GridRun], None] | None, on_done: Callable[[GridResult], None] | None,
                          python: str, t0: float, cluster: Optional[ClusterSession] = None) -> Comparison:
    archs = [a for a in cfg.architectures if a in available]
    grid = _cells(cfg, archs, cfg.seeds)
    n_fault = sum(TARGETS.get(a, {}).get(f) is not None for f in cfg.faults for a in archs) * len(cfg.missions)
    n_sweep = len(cfg.speeds) * len(cfg.missions) * len(cfg.seeds) * len([a for a in archs if a in SPEED_CAPPED])
    actor_grid = (_cells(cfg, archs, cfg.seeds, tag="-actors", missions=[lay.mission for lay in cfg.layouts], with_actors=True)
                  if cfg.with_actors else [])
    if total:
        total(len(grid) + len(actor_grid) + n_fault + n_sweep)
    kw = dict(jobs=cfg.jobs, arch_flag=cfg.arch_flag, python=python, on_start=on_start, on_done=on_done, resume=cfg.resume,
              cluster=cluster)
    entries = [_entry(r) for r in await run_grid(grid, **kw)]
    measured = [e.measures for e in entries if e.measures is not None]
    actor_entries = [_entry(r) for r in await run_grid(actor_grid, **kw)]

    fault_cells = []
    outcomes = []
    for f in cfg.faults:
        for m in cfg.missions:
            for a in archs:
                if TARGETS.get(a, {}).get(f) is None:  # nothing plays that role here: no run, and said so
                    outcomes.append(FaultOutcome(architecture=a, mission=mission_name(m), seed=cfg.seeds[0], fault=f, injected=False,
                                                 verdict="not injected", how=f"{a} has no part for {f} ({ROLES[f]})"))
                    continue
                base = [x.mission_time_s for x in measured if x.architecture == a and x.mission == mission_name(m)]
                at = round(FAULT_AT * float(np.median(base)), 1) if base else 30.0
                fault_cells += _cells(cfg, [a], cfg.seeds[:1], tag=f"-{f}", fault=FaultSpec(name=f, at_s=at), mission=m,  # type: ignore[arg-type]
                                      measured=measured)
    fault_entries = [_entry(r) for r in await run_grid(fault_cells, **kw)]
    for e in fault_entries:
        if e.report is None or e.measures is None:
            outcomes.append(FaultOutcome(architecture=e.architecture, mission=e.mission, seed=e.seed, fault=e.fault or "?",
                                         injected=False, verdict="failed", how=e.error))
            continue
        from sidewalk.report import RunReport

        try:
            rec = load_record(Path(e.out) / "run_record.json")
        except RunRecordError as exc:
            outcomes.append(FaultOutcome(architecture=e.architecture, mission=e.mission, seed=e.seed, fault=e.fault or "?",
                                         injected=False, verdict="failed", how=str(exc)))
            continue
        baseline = [x for x in measured if x.architecture == e.architecture and x.mission == mission_name(e.mission)]
        outcomes.append(judge_fault(RunReport.model_validate(e.report), rec, e.measures, baseline))

    sweep: list[SweepPoint] = []
    sweep_entries: list[RunEntry] = []
    alive = [a for a in archs if a in SPEED_CAPPED]
    highest: dict[str, Optional[float]] = {a: None for a in archs if a in SPEED_CAPPED} if cfg.speeds else {}
    for v in sorted(cfg.speeds):
        if not alive:
            break
        res = [_entry(r) for r in await run_grid(_cells(cfg, alive, cfg.seeds, tag=f"-v{v:g}", speed=v, measured=measured), **kw)]
        sweep_entries += res
        for a in list(alive):
            mine = [e for e in res if e.architecture == a]
            ok = [e for e in mine if e.measures is not None and e.measures.success == 1.0]
            ms = [e.measures for e in mine if e.measures is not None]
            sweep.append(SweepPoint(architecture=a, max_speed=v, runs=len(mine), successes=len(ok),
                                    mean_speed_m_s=float(np.median([m.mean_speed_m_s for m in ms if m.mean_speed_m_s])) if ms else None,
                                    mission_time_s=float(np.median([m.mission_time_s for m in ms])) if ms else None))
            if len(ok) == len(mine):
                highest[a] = v
            else:
                alive.remove(a)

    summary, per_mission = summaries(entries, cfg.missions)
    rows = layout_rows(cfg.layouts, entries + actor_entries)
    return Comparison(
        config=cfg, available=available, requested=list(cfg.architectures),
        runs=entries + actor_entries + fault_entries + sweep_entries,
        summary=summary, per_mission=per_mission,
        faults=outcomes, speed_sweep=sweep, highest_speed=highest,
        glue=[count_glue(SOURCE_ROOT, a) for a in ("codger", "eddie")],
        wall_time_s=round(time.monotonic() - t0, 1), time_mode="lockstep" if cfg.lockstep else "realtime",
        layouts=rows, layout_totals=layout_totals(rows),
    )
