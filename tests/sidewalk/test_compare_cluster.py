"""`sidewalk compare --cluster`: the grid's cells on a Dask scheduler's workers give the local grid's figures (issue 39, item 3).

The cluster is real: a `dask scheduler` and two `dask worker` processes (one thread and one `run`
resource each) on loopback. The grid (the short-hop mission, a file the workers do not have, under
CODGER and EDDIE in lock-step, seed 0) runs once here and once through the cluster; every figure of
compare.json but the machine's (`MACHINE_MEASURES`) is equal.
"""

from __future__ import annotations

import json
import os
import subprocess
import threading
import sys
from pathlib import Path

import pytest

from sidewalk.compare.repeat import MACHINE_MEASURES

DATA = Path(__file__).parent / "data"

#: report fields that measure wall time (or depend on it) and so differ between any two runs
WALL_FIELDS = {"wall_time_s", "rtf_achieved", "modules", "blackboard", "processes"}


def _compare(out: Path, *extra: str, timeout: float) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "sidewalk", "compare", "--missions", str(DATA / "short-hop.yaml"), "--seeds", "1",
           "--faults", "none", "--lockstep", "--out", str(out), "--max-wall-time", "900", *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env={"COLUMNS": "300", **os.environ})


class Cluster:
    """A `dask scheduler` and `dask worker` processes on loopback (no nanny: a worker is the process that runs its cells)."""

    def __init__(self, tmp: Path, workers: int, env: dict[str, str] | None = None) -> None:
        from distributed import Client

        file = tmp / "scheduler.json"
        env = {**os.environ, **(env or {})}
        self.procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
                                        "--no-dashboard", "--scheduler-file", str(file)], env=env,
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        self.workers = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(file),
                                          "--host", "127.0.0.1", "--nthreads", "1", "--resources", "run=1", "--no-dashboard",
                                          "--no-nanny", "--name", f"w{i}", "--local-directory", str(tmp / f"w{i}")],
                                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for i in range(workers)]
        self.procs += self.workers
        with Client(scheduler_file=str(file), timeout=60) as client:  # waits for the scheduler file and the scheduler
            client.wait_for_workers(workers, timeout=120)
            self.address: str = client.scheduler.address

    def close(self) -> None:
        """End every process of the cluster."""
        for p in reversed(self.procs):
            p.terminate()
        for p in reversed(self.procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()


@pytest.fixture
def cluster(tmp_path: Path):
    """Start a scheduler and two one-run workers on loopback; yield the scheduler's address."""
    c = Cluster(tmp_path, 2)
    try:
        yield c.address
    finally:
        c.close()


def _figures(data: dict) -> dict:
    """Return compare.json's summaries without the machine's measures, and each run's report without wall-time fields."""
    def summary(s: dict) -> dict:  # it repeats some measures' medians beside `measures`
        return {**{k: v for k, v in s.items() if k not in MACHINE_MEASURES},
                "measures": {k: v for k, v in s["measures"].items() if k not in MACHINE_MEASURES}}

    def strip(v: object) -> object:  # the recorder may hear one truth sample more or less after the vehicle stopped
        if isinstance(v, dict):
            return {k: strip(x) for k, x in v.items() if k != "n"}
        return [strip(x) for x in v] if isinstance(v, list) else v

    runs = [{"arch": r["architecture"], "exit": r["exit_code"],
             "report": strip({k: v for k, v in (r["report"] or {}).items() if k not in WALL_FIELDS}),
             "measures": {k: v for k, v in (r["measures"] or {}).items() if k not in MACHINE_MEASURES}} for r in data["runs"]]
    return {"summary": {a: summary(s) for a, s in data["summary"].items()},
            "per_mission": [summary(s) for s in data["per_mission"]], "runs": runs}


def _differences(x: object, y: object, at: str = "") -> list[str]:
    """Return where `x` and `y` differ, as paths with both values."""
    if isinstance(x, dict) and isinstance(y, dict):
        return [d for k in dict.fromkeys([*x, *y]) for d in _differences(x.get(k), y.get(k), f"{at}.{k}")]
    if isinstance(x, list) and isinstance(y, list) and len(x) == len(y):
        return [d for i, (u, v) in enumerate(zip(x, y)) for d in _differences(u, v, f"{at}[{i}]")]
    return [] if x == y else [f"{at}: {str(x)[:80]} != {str(y)[:80]}"]


@pytest.mark.missions
@pytest.mark.timeout(2400)  # 348 s at load 7-9, 895 s at load 17 (quiet run not measured): two lock-step short hops here, then on the cluster
def test_the_grid_on_a_two_worker_cluster_gives_the_local_grids_figures(tmp_path: Path, cluster: str) -> None:
    local = _compare(tmp_path / "local", timeout=1100)
    assert local.returncode == 0, local.stderr[-3000:]
    remote = _compare(tmp_path / "remote", "--cluster", cluster, timeout=1100)
    assert remote.returncode == 0, remote.stderr[-3000:]
    a, b = (json.loads((tmp_path / d / "compare.json").read_text()) for d in ("local", "remote"))
    assert a["time_mode"] == b["time_mode"] == "lockstep" and b["config"]["cluster"] == cluster
    assert [r["exit_code"] for r in a["runs"]] == [r["exit_code"] for r in b["runs"]] == [0, 0], [r["error"] for r in b["runs"]]
    fa, fb = _figures(a), _figures(b)
    assert fa == fb, _differences(fa, fb)
    for arch in ("codger", "eddie"):  # each cell's run directory came back whole
        run = tmp_path / "remote" / "runs" / arch / "short-hop" / "seed0"
        assert {"report.json", "run_record.json", "run.mcap", "compare-run.log", "logs"} <= {p.name for p in run.iterdir()}
        assert f"via {cluster}, exit 0" in (run / "compare-run.log").read_text()

    # --resume: the finished cells are not sent again (a sent cell would rewrite its log)
    logs = {p: p.read_text() for p in (tmp_path / "remote").glob("runs/*/*/*/compare-run.log")}
    again = _compare(tmp_path / "remote", "--cluster", cluster, "--resume", timeout=120)
    assert again.returncode == 0, again.stderr[-3000:]
    assert {p: p.read_text() for p in logs} == logs


@pytest.mark.timeout(150)  # 40 s at load 15 (quiet run not measured; two 10 s connect time-outs)
def test_a_cluster_out_of_reach_is_named_in_one_line(tmp_path: Path) -> None:
    r = _compare(tmp_path / "x", "--cluster", "tcp://127.0.0.1:9", timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "--cluster tcp://127.0.0.1:9: cannot reach a Dask scheduler there within 10 s" in " ".join(r.stderr.split())
    r = _compare(tmp_path / "x", "--cluster", "tcp://127.0.0.1:9", "--jobs", "2", timeout=60)
    assert r.returncode == 2 and "leave --jobs out" in " ".join(r.stderr.split())


@pytest.mark.missions
@pytest.mark.timeout(700)  # 212 s beside another mission test at load 9 (quiet run not measured); two cells of ≤ 60 s wall
def test_a_worker_that_dies_mid_run_fails_its_cell_and_the_grid_goes_on(tmp_path: Path) -> None:
    import psutil

    # the scheduler gives up on a task at its first dead worker (its default re-runs it on another up to 3 times)
    c = Cluster(tmp_path, 2, env={"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"})
    killed: list[int] = []
    done = threading.Event()

    def kill_the_first_worker_to_start_a_run() -> None:
        while not done.wait(0.2):
            for w in c.workers:
                kids = psutil.Process(w.pid).children() if w.poll() is None else []
                if any("run" in k.cmdline() for k in kids):
                    w.kill()
                    killed.append(w.pid)
                    return

    killer = threading.Thread(target=kill_the_first_worker_to_start_a_run, daemon=True)
    killer.start()
    try:
        r = _compare(tmp_path / "grid", "--cluster", c.address, "--max-wall-time", "60", timeout=300)
    finally:
        done.set()
        killer.join(timeout=10)
        c.close()
    assert r.returncode == 0 and len(killed) == 1, r.stderr[-3000:]
    runs = json.loads((tmp_path / "grid" / "compare.json").read_text())["runs"]
    dead = [x for x in runs if x["exit_code"] == 255]
    assert len(dead) == 1 and "the worker running it died mid-run" in dead[0]["error"], [x["error"] for x in runs]
    other = next(x for x in runs if x is not dead[0])
    assert other["exit_code"] != 255 and "ran on" in (Path(other["out"]) / "compare-run.log").read_text()
