"""Command-line startup benchmark: how long `sidewalk --help` and a `sidewalk status` that finds nothing take.

Each figure is the wall time [s] of a fresh process (start to exit), `runs` runs each, as p50/p95:

- `python_s`: `python -c pass`, the interpreter's own floor;
- `help_s`: `sidewalk --help`;
- `status_s`: `sidewalk status --json` against a router with nothing else in its namespace (it finds
  the router alone, and waits for the router's heartbeat: up to one period, 1 s);
- `status_no_wait_s`: the same with `--heartbeat-wait 0`: startup, the session and two queries.

The same with `_cpu_s`: the processes' CPU time [s] (user + system), which a busy machine does not
inflate as it does the wall time (`loadavg_1m` says how busy it was). Beside them, from
`python -X importtime` (one run each): `help_import_s` and `status_import_s`, the
time [s] spent importing, and `help_import_top` / `status_import_top`, the slowest top-level imports
([module, ms] including what each imported). Startup is the floor plus the imports.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

from bench.eddie import ROOT, _spawn, _stop
from bench.errors import BenchError
from wire.ports import free_port
from wire.summary import percentiles

__all__ = ["run", "import_times"]

#: The namespace the benchmark's router serves.
NS = "benchcli"


def _sidewalk() -> list[str]:
    """Return the command that runs `sidewalk`: the installed script beside this Python, else `python -m sidewalk`."""
    script = Path(sys.executable).parent / "sidewalk"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "sidewalk"]


def _wall(cmd: list[str], runs: int, ok: tuple[int, ...] = (0,)) -> tuple[list[float], list[float]]:
    """Return the wall time [s] and the CPU time [s] (user + system) of each of `runs` runs of `cmd`.

    Raise BenchError when one exits otherwise than `ok`. The CPU time is what a busy machine does not inflate.
    """
    walls, cpus = [], []
    env = dict(os.environ, COLUMNS="100")
    for _ in range(runs):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        p = subprocess.run(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        walls.append(time.perf_counter() - t0)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append((r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime))
        if p.returncode not in ok:
            raise BenchError(f"{' '.join(cmd[-6:])} exited {p.returncode}: {p.stderr.strip()[-300:]}")
    return walls, cpus


def _p50_p95(xs: list[float]) -> dict[str, float]:
    p50, p95 = percentiles(xs, (50, 95), digits=4)
    return {"p50": p50, "p95": p95}


def import_times(stderr: str) -> tuple[float, list[tuple[str, float]]]:
    """Return the total import time [s] of a `python -X importtime` log and its top-level imports ([ms], slowest first)."""
    top = []
    for line in stderr.splitlines():
        if not line.startswith("import time:"):
            continue
        _self, cumulative, name = line[len("import time:"):].split("|")
        if cumulative.strip() == "cumulative":  # the header
            continue
        if not name.startswith("  "):  # one space after the bar: imported by the program itself
            top.append((name.strip(), int(cumulative) / 1000.0))
    top.sort(key=lambda t: -t[1])
    return sum(ms for _n, ms in top) / 1000.0, top


def _imports(args: list[str], ok: tuple[int, ...] = (0,)) -> tuple[float, list[list]]:
    p = subprocess.run([sys.executable, "-X", "importtime", "-m", "sidewalk", *args], cwd=ROOT, stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True, env=dict(os.environ, COLUMNS="100"))
    if p.returncode not in ok:
        raise BenchError(f"sidewalk {' '.join(args)} exited {p.returncode} under -X importtime")
    total, top = import_times(p.stderr)
    return round(total, 4), [[n, round(ms, 1)] for n, ms in top[:8]]


def run(runs: int = 20) -> dict:
    """Measure the startup figures over `runs` runs each; return them as one JSON-able dict."""
    sidewalk = _sidewalk()
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = _spawn(["-m", "sidewalk", "up", "router", "--ns", NS, "--listen", endpoint], "router ready")
    try:
        status = ["status", "--json", "--ns", NS, "--connect", endpoint]
        # the router alone is alive: status exits 0 (nothing wedged)
        python, python_cpu = _wall([sys.executable, "-c", "pass"], runs)
        helps, help_cpu = _wall([*sidewalk, "--help"], runs)
        statuses, status_cpu = _wall([*sidewalk, *status], runs)
        no_wait, no_wait_cpu = _wall([*sidewalk, *status, "--heartbeat-wait", "0"], runs)
        help_import, help_top = _imports(["--help"])
        status_import, status_top = _imports([*status, "--heartbeat-wait", "0"])
    finally:
        _stop(router)
    return {
        "runs": runs, "command": " ".join(sidewalk),
        "python_s": _p50_p95(python), "help_s": _p50_p95(helps), "status_s": _p50_p95(statuses),
        "status_no_wait_s": _p50_p95(no_wait),
        "python_cpu_s": _p50_p95(python_cpu), "help_cpu_s": _p50_p95(help_cpu), "status_cpu_s": _p50_p95(status_cpu),
        "status_no_wait_cpu_s": _p50_p95(no_wait_cpu), "loadavg_1m": round(os.getloadavg()[0], 2),
        "help_import_s": help_import, "help_import_top": help_top,
        "status_import_s": status_import, "status_import_top": status_top,
    }
