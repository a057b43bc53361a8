"""`compare.md`: the comparison as tables a person reads."""

from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from sidewalk.compare.comparison import FAULT_AT, SPEED_CAPPED, Comparison
from sidewalk.compare.fault_outcome import BEFORE_S, HELD_S, SLOWER, WORSE_M
from sidewalk.compare.faults import JUMP_M, ROLES, TARGETS, WEDGE_S
from sidewalk.compare.glue import TRANSPORT, GlueCount
from sidewalk.compare.measures import MEASURES, OBSERVERS
from sidewalk.compare.summary import Spread

__all__ = ["render_markdown", "fmt_spread"]


def _num(v: Optional[float]) -> str:
    if v is None:
        return "–"
    if abs(v) >= 1000:
        return f"{v:,.0f}"
    if abs(v) >= 100:
        return f"{v:.0f}"
    if abs(v) >= 10:
        return f"{v:.1f}"
    return f"{v:.2f}"


def fmt_spread(s: Spread) -> str:
    """Return 'median [min–max]' (just the value when all runs agree; '–' when none has it)."""
    if s.median is None:
        return "–"
    if s.min == s.max:
        return _num(s.median)
    return f"{_num(s.median)} [{_num(s.min)}–{_num(s.max)}]"


def _table(head: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|", *("| " + " | ".join(r) + " |" for r in rows)]


def _layouts(c: Comparison) -> list[str]:
    """Return the generated layouts' section: totals per kind and architecture, then a row per layout."""
    kinds = ", ".join(dict.fromkeys(f"{t.kind}" for t in c.layout_totals))
    out = ["## Generated layouts", "",
           f"Layouts of `sidewalk worldgen` ({kinds}), seeds 0..N-1, one mission each (start to the delivery mailbox); "
           "success by truth; goal error median and 90th percentile over the layouts that reported one.", ""]
    rows = [[t.kind, t.architecture, "with" if t.actors else "without", f"{t.successes}/{t.layouts}", _num(t.goal_error_median_m),
             _num(t.goal_error_p90_m), str(t.collisions)] for t in c.layout_totals]
    out += _table(["kind", "arch", "actors", "success (truth)", "goal error median [m]", "goal error p90 [m]", "collisions"], rows) + [""]
    rows = [[r.layout, r.architecture, "with" if r.actors else "without", str(r.seed), "✔" if r.success else "✘", _num(r.goal_error_m),
             str(r.collisions), r.reason[:100]] for r in c.layouts]
    out += ["Per layout:", ""] + _table(["layout", "arch", "actors", "seed", "truth", "goal error [m]", "collisions", "why it failed"], rows)
    return out + [""]


def render_markdown(c: Comparison, command: str = "") -> str:
    """Return compare.md for a comparison."""
    archs = list(c.summary)
    cfg = c.config
    out = ["# Sidewalk compare: CODGER and EDDIE on the same missions", ""]
    if command:
        out += [f"Command: `{command}` — {c.wall_time_s:.0f} s wall.", ""]
    missing = [a for a in c.requested if a not in c.available]
    timing = ("lock-step (the simulator waits for every module; `--realtime` for real time)" if c.time_mode == "lockstep"
              else f"real time at RTF {cfg.rtf:g}")
    out += [f"Missions: {', '.join(cfg.missions)}; seeds {', '.join(map(str, cfg.seeds))}; {timing}.",
            f"Architectures run: **{', '.join(archs) or 'none'}** (available to `sidewalk run`: {', '.join(c.available)})."]
    if missing:
        out.append(f"Not run: {', '.join(missing)} — `sidewalk run --help` does not offer it on this build; no rows are shown for it.")
    out += ["", "Every figure is `median [min–max]` over the runs (seeds × missions), the range being the spread; "
            "a single figure means every run gave it. Latencies are by the recorder's **sim clock** (run.mcap log "
            "times); no wall latency is shown (a sim figure divided by the real-time factor is not a wall measurement).", ""]
    for group in ("outcome", "accuracy", "reaction", "cost"):
        out += [f"## {group.capitalize()}", ""]
        rows = []
        if group == "outcome":
            rows.append(["runs", *(str(c.summary[a].runs) for a in archs)])
            rows.append(["success rate (truth)", *(f"{c.summary[a].success_rate:.0%}" for a in archs)])
            if any(c.summary[a].unreported for a in archs):
                rows.append(["of the runs, failed without a report", *(str(c.summary[a].unreported) for a in archs)])
        for key, (g, label) in MEASURES.items():
            if g != group or key == "success":
                continue
            rows.append([label, *(fmt_spread(c.summary[a].measures[key]) for a in archs)])
        out += _table(["measure", *archs], rows) + [""]
        if group == "outcome" and c.per_mission:
            pm = [[s.mission, s.architecture, str(s.runs), f"{s.success_rate:.0%}", fmt_spread(s.measures["mission_time_s"]),
                   fmt_spread(s.measures["goal_error_m"]), fmt_spread(s.measures["position_error_rms_m"])] for s in c.per_mission]
            out += ["Per mission:", ""] + _table(["mission", "arch", "runs", "success", "mission time [s]", "goal error [m]",
                                                  "position error rms [m]"], pm) + [""]
        if group == "outcome" and any(s.unreported for s in c.summary.values()):
            out += ["A run that wrote no report failed: it counts in the success rate and has no other figure "
                    "(its reason is in *Runs*).", ""]
        if group == "reaction":
            out += ["Position query latency is not measured inside a run (the PILOT's pose lookups on the blackboard and "
                    "EDDIE's position requests carry no stamps to the recording); `sidewalk bench blackboard` (CODGER) and "
                    "`sidewalk bench eddie` (EDDIE) measure it on the bench.", ""]
        if group == "cost":
            out += [f"Processes counted in `modules`: every process but {', '.join(OBSERVERS)}. Per process (median over baseline runs):", ""]
            rows = []
            for a in archs:
                reports = [r.report for r in c.runs if r.architecture == a and r.report and r.fault is None and r.max_speed is None]
                names = sorted({n for rep in reports for n in rep["modules"]})
                for n in names:
                    mods = [rep["modules"][n] for rep in reports if n in rep["modules"]]
                    spans = [rep["sim_time_s"] for rep in reports if n in rep["modules"]]
                    med = lambda k: float(np.median([m[k] for m in mods]))  # noqa: E731
                    own = lambda m, k: m[k] - m.get(f"barrier_{k}", 0)  # noqa: E731 - the barrier's is the run mode's
                    rate = float(np.median([own(m, "msgs_out") / s for m, s in zip(mods, spans) if s > 0])) if spans else 0.0
                    brate = float(np.median([own(m, "bytes_out") / s for m, s in zip(mods, spans) if s > 0])) if spans else 0.0
                    barrier = float(np.median([m.get("barrier_msgs_out", 0) / s for m, s in zip(mods, spans) if s > 0])) if spans else 0.0
                    rows.append([a, n, _num(med("cpu_s")), _num(med("rss_mb")), _num(rate), _num(brate), _num(barrier)])
            out += _table(["arch", "process", "CPU [s]", "RSS [MB]", "msgs out / s sim", "bytes out / s sim",
                           "barrier msgs out / s sim"], rows) + [""]
            if cfg.lockstep:
                out += ["This grid ran in lock-step: every process answered the barrier's asks at each step. Those messages are "
                        "counted apart (the last column; the run mode's cost, not the architecture's); the CPU they took cannot "
                        "be told apart and is in the CPU figures. Compare the architectures' cost on a real-time grid "
                        "(`--realtime`).", ""]
    if c.layouts:
        out += _layouts(c)
    out += ["## Runs", ""]
    rows = []
    for r in c.runs:
        m = r.measures
        what = r.fault or (f"v≤{r.max_speed:g}" if r.max_speed else ("actors" if r.actors else ""))
        if m is None:
            rows.append([r.architecture, Path(r.mission).stem, str(r.seed), what, "✘ no report", "–", "–", "–", "–", "–", r.error[:80]])
            continue
        rows.append([r.architecture, Path(r.mission).stem, str(r.seed), what, "✔" if m.success else "✘", _num(m.mission_time_s),
                     _num(m.goal_error_m), _num(m.position_error_rms_m), _num(m.sense_to_act_ms_p50), _num(m.cpu_s),
                     (r.report or {}).get("reason", "")[:80]])
    out += _table(["arch", "mission", "seed", "variant", "truth", "time [s]", "goal err [m]", "pos err rms [m]",
                   "s→a p50 [ms sim]", "CPU [s]", "reason"], rows) + [""]
    if cfg.faults:
        out += ["## Faults", "",
                f"Each fault once per mission and architecture (seed {cfg.seeds[0]}), at {FAULT_AT:.0%} of the mission's median "
                f"baseline time. kill-*: SIGKILL, then started again; wedge-*: SIGSTOP for {WEDGE_S:g} s sim; "
                f"position-jump: the estimate moved {JUMP_M:g} m. Degraded: succeeded, but slower than {SLOWER:g}× the baseline, "
                f"a position error peak over {WORSE_M:g} m above it, longer off the path, or a collision. Recovery: from the "
                f"injection until the vehicle drove at ≥ half its speed of the {BEFORE_S:g} s before for {HELD_S:g} s with its "
                "position error under max(1 m, 2× the error at injection) [s sim].", ""]
        hits = [[f, ROLES[f], *(TARGETS.get(a, {}).get(f) or "— (no such part)" for a in archs)] for f in cfg.faults if f in ROLES]
        out += ["Each fault takes away the same role in each architecture:", ""]
        out += _table(["fault", "role", *archs], hits) + [""]
        rows = [[f.fault, f.architecture, f.mission, f"{f.at_s:.0f}" if f.at_s is not None else "–", f.verdict,
                 _num(f.recovery_s) if f.recovery_s is not None else ("never" if f.injected else "–"), f.how[:120]] for f in c.faults]
        out += _table(["fault", "arch", "mission", "at [s sim]", "verdict", "recovery [s sim]", "how / why"], rows) + [""]
    if cfg.speeds:
        out += ["## Speed sweep", "", "The PILOT's speed cap (`sidewalk run --max-speed`) raised step by step; an architecture "
                "stops at the first cap where a seed fails. Swept: " + ", ".join(a for a in archs if a in SPEED_CAPPED)
                + " (EDDIE: the mission service's route speed and the controller's top speed).", ""]
        rows = [[p.architecture, f"{p.max_speed:g}", f"{p.successes}/{p.runs}", _num(p.mean_speed_m_s), _num(p.mission_time_s)]
                for p in c.speed_sweep]
        out += _table(["arch", "cap [m/s]", "successes", "mean speed [m/s]", "mission time [s]"], rows) + [""]
        out += ["Highest cap with success on every seed: " + ", ".join(
            f"{a} {('%g m/s' % v) if v is not None else 'none'}" for a, v in c.highest_speed.items()), ""]
    out += ["## Lines of glue", "",
            "Counted by `sidewalk.compare.glue.count_glue` over the files each architecture's processes reach by static "
            "imports from its entry points (the `__main__.py` of every process its launch plans start, "
            "`sidewalk.processes`: `codger.<name>` for CODGER, `eddie.<name>` for EDDIE; `wire/` excluded; a file is glue "
            f"by its own imports, not its package's). *Substrate*: files importing the transport ({', '.join(TRANSPORT)}). "
            "*Glue*: substrate, or files importing substrate. *Algorithm*: the rest. Lines are logical lines: no blanks, comments or docstrings.", ""]
    rows = [[g.architecture, str(g.glue_lines) if g.present else "absent", str(g.glue_files), str(g.substrate_lines),
             str(g.algorithm_lines), str(g.algorithm_files)] for g in c.glue]
    out += _table(["arch", "glue lines", "glue files", "of which substrate", "algorithm lines", "algorithm files"], rows) + [""]
    out += glue_appendix(c.glue)
    return "\n".join(out) + "\n"


def glue_appendix(glue: Sequence[GlueCount]) -> list[str]:
    """Return the appendix of the glue count: every counted file per architecture, its kind and logical lines."""
    out = ["## Appendix: the files counted", "",
           "Every file each architecture's processes reach, as the rule above classed it, with its logical lines: the "
           "sums are the table's.", ""]
    for g in glue:
        if not g.present:
            continue
        rows = [[f, "glue", str(n)] for f, n in g.glue_by_file.items()] + [[f, "algorithm", str(n)] for f, n in g.algorithm_by_file.items()]
        out += [f"### {g.architecture}", ""] + _table(["file", "kind", "lines"], sorted(rows)) + [""]
    return out
