"""Is a comparison reproducible? Two `compare.json` of the same command, measure by measure.

Issue 10 asks that the same command run twice give the same table within the spread it reports.
Each architecture's summary measure (`ArchSummary.measures`: median, min, max over the runs) of
grid A is held against grid B's, over every mission together (`summary`, mission "*") and per mission
(`per_mission`: a median over two missions' runs pooled falls between the missions, so per mission is
the finer test): the measure repeats when each median lies within the other grid's range
(`within_spread`). Fault verdicts (one run per fault, no spread) repeat when the verdict is
the same; the speed sweep when the highest speed with success on every seed is the same.

Two lock-step grids hold the simulated run still while every module works, so what the run does
must repeat; what the machine spent doing it (`MACHINE_MEASURES`: wall time, CPU, memory, and the
messages per sim second, which include each process's heartbeat once a wall second) cannot, by
construction. Between lock-step grids those are checked and shown apart (`machine`) and left out of
the verdict; between real-time grids every measure counts.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

from pydantic import BaseModel, ConfigDict, ValidationError

from sidewalk.compare.errors import CompareError
from sidewalk.compare.summary import ArchSummary, Spread, within_spread
from sidewalk.compare.tables import fmt_spread

__all__ = ["MACHINE_MEASURES", "MeasureRepeat", "VerdictRepeat", "RepeatCheck", "load_summary", "check_repeat", "render_repeat"]


#: measures of what the machine spent, not of what the simulated run did
MACHINE_MEASURES = frozenset({"cpu_s", "cpu_s_modules", "rss_mb", "wall_time_s",
                              "messages_per_s", "bytes_per_s"})


class MeasureRepeat(BaseModel):
    """One measure of one architecture in both grids, and whether it repeats."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    mission: str  # "*": every mission together
    measure: str
    a: Spread
    b: Spread
    repeats: bool
    #: a measure of the machine between lock-step grids: shown, not counted in the verdict
    machine: bool = False


class VerdictRepeat(BaseModel):
    """One fault (or the speed sweep) of one architecture in both grids: its verdict in each."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    what: str
    a: Optional[str] = None
    b: Optional[str] = None
    repeats: bool


class RepeatCheck(BaseModel):
    """Every measure and verdict of grid `a` against grid `b`; `repeats` when all of them do."""

    model_config = ConfigDict(frozen=True)

    a: str
    b: str
    command_a: Optional[dict] = None
    command_b: Optional[dict] = None
    same_config: bool
    measures: list[MeasureRepeat]
    verdicts: list[VerdictRepeat]
    repeated: int
    total: int
    repeats: bool
    #: both grids in lock-step: the machine's measures are apart (`MeasureRepeat.machine`)
    lockstep: bool = False
    machine_repeated: int = 0
    machine_total: int = 0


def load_summary(path: Path) -> dict:
    """Read a `compare.json` (or the directory holding it); raise CompareError naming the file and what is wrong."""
    f = path / "compare.json" if path.is_dir() else path
    try:
        data = json.loads(f.read_text())
    except FileNotFoundError:
        raise CompareError(f"{f}: no such file (give a `sidewalk compare --out` directory or its compare.json)") from None
    except json.JSONDecodeError as exc:
        raise CompareError(f"{f}: not JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None
    if not isinstance(data, dict) or not isinstance(data.get("summary"), dict):
        raise CompareError(f"{f}: no `summary` object: not a compare.json")
    summary = {}
    for arch, v in data["summary"].items():
        try:
            summary[arch] = ArchSummary.model_validate(v)
        except ValidationError as exc:
            err = exc.errors()[0]
            raise CompareError(f"{f}: summary.{arch}.{'.'.join(str(x) for x in err['loc'])}: {err['msg']}") from None
    data["summary"] = summary
    per_mission = {}
    for i, v in enumerate(data.get("per_mission") or []):
        try:
            one = ArchSummary.model_validate(v)
        except ValidationError as exc:
            err = exc.errors()[0]
            raise CompareError(f"{f}: per_mission[{i}].{'.'.join(str(x) for x in err['loc'])}: {err['msg']}") from None
        per_mission[(one.architecture, one.mission)] = one
    data["per_mission"] = per_mission
    return data


def _verdicts(data: dict) -> dict[tuple[str, str], str]:
    """Return {(architecture, what): verdict} for the faults and the speed sweep of one grid."""
    out: dict[tuple[str, str], str] = {}
    for f in data.get("faults") or []:
        if isinstance(f, dict) and "architecture" in f and "fault" in f:
            out[(f["architecture"], f"fault {f['fault']} on {f.get('mission', '?')}")] = str(f.get("verdict"))
    for arch, v in (data.get("highest_speed") or {}).items():
        out[(arch, "highest speed with success on every seed [m/s]")] = "none" if v is None else f"{float(v):g}"
    return out


def _config(data: dict) -> dict:
    """Return what makes two grids the same command: missions, seeds, RTF, architectures, faults, speeds."""
    c = data.get("config") or {}
    return {k: c.get(k) for k in ("missions", "seeds", "rtf", "architectures", "faults", "speeds")}


def check_repeat(a: dict, b: dict, *, name_a: str = "a", name_b: str = "b") -> RepeatCheck:
    """Hold grid `a`'s summary (from `load_summary`) against grid `b`'s, measure by measure and verdict by verdict."""
    measures: list[MeasureRepeat] = []
    lockstep = a.get("time_mode") == b.get("time_mode") == "lockstep"
    pairs = [((arch, "*"), sa, b["summary"].get(arch)) for arch, sa in a["summary"].items()]
    pairs += [(key, sa, b["per_mission"].get(key)) for key, sa in a["per_mission"].items()]
    for (arch, mission), sa, sb in pairs:
        for name, spa in sa.measures.items():
            spb = sb.measures.get(name, Spread()) if sb is not None else Spread()
            measures.append(MeasureRepeat(architecture=arch, mission=mission, measure=name, a=spa, b=spb,
                                          repeats=within_spread(spa, spb), machine=lockstep and name in MACHINE_MEASURES))
    va, vb = _verdicts(a), _verdicts(b)
    verdicts = [VerdictRepeat(architecture=k[0], what=k[1], a=va.get(k), b=vb.get(k), repeats=va.get(k) == vb.get(k))
                for k in dict.fromkeys([*va, *vb])]
    rows = [*(m for m in measures if not m.machine), *verdicts]
    machine = [m for m in measures if m.machine]
    ok = sum(r.repeats for r in rows)
    return RepeatCheck(a=name_a, b=name_b, command_a=_config(a), command_b=_config(b), same_config=_config(a) == _config(b),
                       measures=measures, verdicts=verdicts, repeated=ok, total=len(rows), repeats=ok == len(rows),
                       lockstep=lockstep, machine_repeated=sum(m.repeats for m in machine), machine_total=len(machine))


def render_repeat(check: RepeatCheck) -> str:
    """Return the check as Markdown: a line of totals, then the measures and verdicts that do not repeat, then all."""
    lines = [f"# `{check.a}` against `{check.b}`", ""]
    if not check.same_config:
        lines += [f"**Not the same command**: {check.command_a} against {check.command_b}.", ""]
    lines += [f"{check.repeated} of {check.total} measures and verdicts repeat (a measure repeats when each grid's median lies "
              "within the other's range; a verdict when it is the same).", ""]
    if check.lockstep:
        lines += [f"Both grids ran in lock-step: the {check.machine_total} measures of the machine (wall time, CPU, memory, "
                  f"messages per sim second) are not counted; {check.machine_repeated} of them repeat.", ""]
    differ = [m for m in check.measures if not m.repeats and not m.machine]
    vdiffer = [v for v in check.verdicts if not v.repeats]
    if differ or vdiffer:
        lines += ["## Not repeated", "", f"| arch | mission | measure or verdict | {check.a} | {check.b} |", "|---|---|---|---|---|"]
        lines += [f"| {m.architecture} | {m.mission} | {m.measure} | {fmt_spread(m.a)} | {fmt_spread(m.b)} |" for m in differ]
        lines += [f"| {v.architecture} | | {v.what} | {v.a or '–'} | {v.b or '–'} |" for v in vdiffer]
        lines.append("")
    lines += ["## Every measure (median [min–max]; mission * = every mission together)", "",
              f"| arch | mission | measure | {check.a} | {check.b} | repeats |", "|---|---|---|---|---|---|"]
    lines += [f"| {m.architecture} | {m.mission} | {m.measure} | {fmt_spread(m.a)} | {fmt_spread(m.b)} | "
              f"{('yes' if m.repeats else '**no**') + (' (machine, not counted)' if m.machine else '')} |"
              for m in check.measures]
    if check.verdicts:
        lines += ["", "## Faults and speed sweep", "", f"| arch | what | {check.a} | {check.b} | repeats |", "|---|---|---|---|---|"]
        lines += [f"| {v.architecture} | {v.what} | {v.a or '–'} | {v.b or '–'} | {'yes' if v.repeats else '**no**'} |"
                  for v in check.verdicts]
    return "\n".join(lines) + "\n"
