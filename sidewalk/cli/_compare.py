"""`sidewalk compare`: run the comparison grid and write compare.json, compare.md and plots."""

from __future__ import annotations

import asyncio
import math
import shlex
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from sidewalk.json_out import dumps

__all__ = ["register", "compare", "compare_check"]


def _list(text: str, flag: str) -> tuple[str, ...]:
    items = tuple(t.strip() for t in text.split(",") if t.strip())
    if not items:
        raise typer.BadParameter(f"{text!r} names nothing (comma-separated list)", param_hint=flag)
    return items


def _speeds(text: str) -> tuple[float, ...]:
    try:
        v = tuple(float(t) for t in _list(text, "--speed-sweep"))
    except ValueError:
        raise typer.BadParameter(f"{text!r} is not a list of speeds [m/s], e.g. 1.0,2.0,3.0", param_hint="--speed-sweep") from None
    if not all(math.isfinite(x) and x > 0 for x in v):
        raise typer.BadParameter(f"{text!r}: speeds must be > 0 [m/s]", param_hint="--speed-sweep")
    return v


def _fault_list(text: str) -> tuple[str, ...]:
    """`all` (the default: every fault), `none`, or a comma-separated list of fault names."""
    from sidewalk.compare.faults import FAULTS

    if text.strip() == "all":
        return FAULTS
    if text.strip() == "none":
        return ()
    return _list(text, "--faults")


def compare(
    missions: Annotated[Optional[str], typer.Option(help="Missions (comma-separated names or files; default: campus-tour,amv-delivery, none with --generated)")] = None,
    worlds: Annotated[Optional[str], typer.Option(help="Only missions on these worlds (comma-separated; default: each mission's own)")] = None,
    seeds: Annotated[int, typer.Option(help="Seeds 0..N-1: each runs on every architecture")] = 3,
    rtf: Annotated[float, typer.Option(help="Real-time factor of every run (with --realtime)")] = 8.0,
    lockstep: Annotated[bool, typer.Option("--lockstep/--realtime", help="Lock-step (default: the simulator waits for every module; the same command gives the same table) or real time at --rtf (latency under load is measured)")] = True,
    arch: Annotated[str, typer.Option("--arch", help="Architectures to compare (those `sidewalk run` offers are run)")] = "codger,eddie",
    faults: Annotated[Optional[str], typer.Option(help="Faults, each once per mission × architecture (default: all six; `none` to skip; with --generated none): kill-central,kill-service,kill-perception,wedge-driver,wedge-planner,position-jump")] = None,
    speed_sweep: Annotated[Optional[str], typer.Option("--speed-sweep", help="Speed caps (m/s) to sweep, e.g. 1.0,2.0,3.0")] = None,
    out: Annotated[Path, typer.Option(help="Output directory (compare.json, compare.md, *.png, runs/)")] = Path("runs/compare"),
    jobs: Annotated[int, typer.Option(help="Runs at a time (1 on a 2-core machine: runs measure time)")] = 1,
    max_wall_time: Annotated[float, typer.Option(help="Give each run up after this wall time (s); a lock-step EDDIE run takes 5-10 min here")] = 3600.0,
    resume: Annotated[bool, typer.Option("--resume", help="Reuse runs in --out whose report is of the same cell (architecture, mission, seed, fault, speed cap)")] = False,
    cluster: Annotated[Optional[str], typer.Option(help="Run the cells on this Dask scheduler's workers (tcp://HOST:8786), one run per worker, their run directories brought back into --out")] = None,
    generated: Annotated[Optional[str], typer.Option(help="Generated layouts KIND:N[,KIND:N] (e.g. suburb:20, marked-road:10, campus:10): seeds 0..N-1 of `sidewalk worldgen KIND`, written into OUT/layouts/, one mission each")] = None,
    with_actors: Annotated[bool, typer.Option("--with-actors", help="Run each generated layout once more with its actors file (streets: a walker in the lane, a parked car; campus: a walker on the walk, another crossing the terrace walk)")] = False,
    road_method: Annotated[Optional[str], typer.Option(help="`sidewalk run --road-method` of every run: perception, scarf, yarf or alvinn (default: the run's)")] = None,
) -> None:
    """Run every mission × seed × architecture (and faults, speed sweep) as `sidewalk run` processes; write tables and plots."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from sidewalk.compare.comparison import CompareConfig, mission_world, run_comparison
    from sidewalk.compare.errors import CompareError
    from sidewalk.compare.faults import FAULTS
    from sidewalk.compare.grid import ARCHITECTURES, available_architectures
    from sidewalk.compare.plots import plot_comparison
    from sidewalk.compare.tables import render_markdown

    console = Console(stderr=True)
    archs = _list(arch, "--arch")
    for a in archs:
        if a not in ARCHITECTURES:
            raise typer.BadParameter(f"unknown architecture {a!r}; known: {', '.join(ARCHITECTURES)}", param_hint="--arch")
    fault_list = _fault_list(faults if faults is not None else ("none" if generated else "all"))
    for f in fault_list:
        if f not in FAULTS:
            raise typer.BadParameter(f"unknown fault {f!r}; known: {', '.join(FAULTS)}", param_hint="--faults")
    if seeds < 1 or jobs < 1 or not (math.isfinite(rtf) and rtf > 0):
        raise typer.BadParameter("--seeds and --jobs must be ≥ 1 and --rtf > 0")
    if cluster is not None and jobs != 1:
        raise typer.BadParameter("the cluster's workers set how many runs go at once (one per worker); leave --jobs out", param_hint="--jobs")
    if with_actors and not generated:
        raise typer.BadParameter("--with-actors runs generated layouts with their actors files: give --generated", param_hint="--with-actors")
    if road_method is not None and road_method not in ("perception", "scarf", "yarf", "alvinn"):
        raise typer.BadParameter(f"unknown method {road_method!r}; known: perception, scarf, yarf, alvinn", param_hint="--road-method")
    mission_list = _list(missions, "--missions") if missions is not None else (() if generated else ("campus-tour", "amv-delivery"))
    layouts = []
    try:
        if generated:
            from sidewalk.compare.layouts import parse_generated, write_layouts

            layouts = write_layouts(parse_generated(generated), out)
            mission_list = (*mission_list, *(lay.mission for lay in layouts))
        if worlds:
            keep = set(_list(worlds, "--worlds"))
            mission_list = tuple(m for m in mission_list if mission_world(m) in keep or mission_world(m) is None)
            if not mission_list:
                raise CompareError(f"--worlds {worlds}: none of the missions runs on these worlds")
        for m in mission_list:
            mission_world(m)
    except CompareError as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from None
    available, arch_flag = available_architectures()
    cfg = CompareConfig(missions=mission_list, seeds=tuple(range(seeds)), rtf=rtf, architectures=archs, faults=fault_list,
                        speeds=_speeds(speed_sweep) if speed_sweep else (), out=out, jobs=jobs, arch_flag=arch_flag,
                        max_wall_time_s=max_wall_time, resume=resume, lockstep=lockstep, cluster=cluster, layouts=tuple(layouts),
                        with_actors=with_actors, road_method=road_method)
    skipped = [a for a in archs if a not in available]
    if skipped:
        console.print(f"[yellow]not available in `sidewalk run`: {', '.join(skipped)} — compared without it[/yellow]")
    with Progress(TextColumn("[bold]compare"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[now]}"),
                  TimeElapsedColumn(), console=console) as bar:
        task = bar.add_task("grid", total=1, now="")

        def total(n: int) -> None:
            bar.update(task, total=max(1, n))

        def started(r) -> None:  # noqa: ANN001 - GridRun
            bar.update(task, now=r.label)

        def done(res) -> None:  # noqa: ANN001 - GridResult
            mark = {0: "[green]✔[/green]", 1: "[red]✘[/red]"}.get(res.exit_code, f"[red]exit {res.exit_code}[/red]")
            bar.console.print(f"{mark} {res.run.label}")
            bar.advance(task)

        try:
            result = asyncio.run(run_comparison(cfg, available, total=total, on_start=started, on_done=done))
        except KeyboardInterrupt:
            console.print("[yellow]interrupted[/yellow]")
            raise typer.Exit(130) from None
        except CompareError as exc:
            bar.stop()
            console.print(f"[red]error:[/red] {exc}", soft_wrap=True)
            raise typer.Exit(2) from None
    out.mkdir(parents=True, exist_ok=True)
    (out / "compare.json").write_text(dumps(result.model_dump(mode="json"), indent=1) + "\n")
    command = "sidewalk " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    (out / "compare.md").write_text(render_markdown(result, command))
    plots = plot_comparison(result, out)
    console.print(f"wrote {out / 'compare.json'}, {out / 'compare.md'}, {', '.join(str(p) for p in plots)} "
                  f"({result.wall_time_s:.0f} s)")


def compare_check(
    a: Annotated[Path, typer.Argument(help="A `sidewalk compare --out` directory (or its compare.json)")],
    b: Annotated[Path, typer.Argument(help="The same command's second grid")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the check as one JSON object")] = False,
    out: Annotated[Optional[Path], typer.Option(help="Also write the Markdown table here")] = None,
) -> None:
    """Hold two grids of the same command against each other: does each median lie within the other's range? Exit 1 if not."""
    from rich.console import Console

    from sidewalk.compare.errors import CompareError
    from sidewalk.compare.repeat import check_repeat, load_summary, render_repeat

    console = Console(stderr=True)
    try:
        check = check_repeat(load_summary(a), load_summary(b), name_a=str(a), name_b=str(b))
    except CompareError as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from None
    text = render_repeat(check)
    if out is not None:
        out.write_text(text)
    print(dumps(check.model_dump(mode="json"), indent=1) if as_json else text, end="" if not as_json else "\n")
    raise typer.Exit(0 if check.repeats else 1)


def register(app: typer.Typer) -> None:
    """Add `compare` and `compare-check` to the top-level app."""
    app.command("compare")(compare)
    app.command("compare-check")(compare_check)
