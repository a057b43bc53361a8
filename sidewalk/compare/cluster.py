"""The grid's runs on a Dask distributed cluster: one cell a task, each run with all its processes on one worker host.

`sidewalk compare --cluster tcp://HOST:8786` connects to a scheduler the user started (`dask scheduler`)
with workers on the hosts that are to run (`dask worker tcp://HOST:8786 --nthreads 1 --resources run=1`).
Each cell is one task, `run_cell`, that the worker imports from its own installed `sidewalk`: it runs the
cell's `sidewalk run` in a temporary directory on that host and returns the run directory as a tar, which
the client unpacks into the cell's `out`. A task asks for the `run` resource (or, with workers that offer
none, a worker has one thread), so a worker holds one run at a time and a lock-step run has its cores.
"""

from __future__ import annotations

import asyncio
import io
import shutil
import socket
import subprocess
import sys
import tarfile
import tempfile
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

from sidewalk.compare.errors import ClusterError
from sidewalk.compare.grid import GridRun
from wire.lifeline import die_with_parent

__all__ = ["ClusterCell", "ClusterSession", "run_cell", "connect", "CONNECT_TIMEOUT_S", "RUN_RESOURCE", "RUN_LOG"]

#: give up reaching the scheduler after this long [s]
CONNECT_TIMEOUT_S = 10.0

#: the worker resource a cell takes one unit of (`dask worker … --resources run=1`)
RUN_RESOURCE = "run"

#: the file in a cell's run directory that holds the output of its `sidewalk run`
RUN_LOG = "compare-run.log"


@dataclass(frozen=True)
class ClusterCell:
    """A cell run on a worker: its exit code, the host it ran on and its run directory as an uncompressed tar."""

    exit_code: int
    host: str
    tar: bytes


def run_cell(run: GridRun, arch_flag: bool, mission_file: Optional[tuple[str, bytes]] = None) -> ClusterCell:
    """Run one cell's `sidewalk run` in a temporary directory on this host; return its run directory as a tar.

    `mission_file`: (file name, bytes) of a mission that is a file on the client, written beside the run.
    """
    tmp = Path(tempfile.mkdtemp(prefix="sidewalk-cell-"))
    try:
        out = tmp / "run"
        out.mkdir()
        here = {"out": out}
        if mission_file is not None:
            (tmp / mission_file[0]).write_bytes(mission_file[1])
            here["mission"] = str(tmp / mission_file[0])
        cmd = [sys.executable, *run.model_copy(update=here).argv(arch_flag=arch_flag)]
        with open(out / RUN_LOG, "wb") as log:
            code = subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=log, stderr=log, cwd=tmp,
                                  preexec_fn=die_with_parent()).returncode
        buf = io.BytesIO()
        with tarfile.open(fileobj=buf, mode="w") as tar:
            tar.add(out, arcname=".")
        return ClusterCell(exit_code=code, host=socket.gethostname(), tar=buf.getvalue())
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _mission_file(run: GridRun) -> Optional[tuple[str, bytes]]:
    """Return the mission to ship with the cell when it names a file here (a mission name resolves on the worker)."""
    from sidewalk.missions import mission_path

    path = mission_path(run.mission)
    return (path.name, path.read_bytes()) if Path(run.mission).exists() else None


class ClusterSession:
    """A connected client of the scheduler at `address`, and the resources its tasks ask for."""

    def __init__(self, client: Any, address: str, resources: Optional[dict[str, int]]) -> None:
        self.client, self.address, self.resources = client, address, resources

    async def run(self, run: GridRun, *, arch_flag: bool) -> int:
        """Run the cell on a worker and write its run directory into `run.out`; return its exit code.

        A cell that could not run (its worker died, the worker lacks `sidewalk`) returns 255, its reason the
        last line of `RUN_LOG`; the grid goes on.
        """
        from distributed import KilledWorker

        if run.world and Path(run.world).exists():
            return self._failed(run, f"world {run.world} is a file on this host; a worker finds worlds by name in its own package")
        try:
            fut = self.client.submit(run_cell, run, arch_flag, _mission_file(run), pure=False, resources=self.resources,
                                     key=f"sidewalk-run-{run.out.name}-{run.architecture}-{Path(run.mission).stem}-{uuid.uuid4().hex[:8]}")
            cell: ClusterCell = await fut
        except KilledWorker as exc:
            return self._failed(run, f"the worker running it died mid-run ({exc})")
        except ModuleNotFoundError as exc:
            return self._failed(run, f"the worker lacks the sidewalk package ({exc}); install it there")
        except (OSError, asyncio.CancelledError, asyncio.TimeoutError) as exc:
            return self._failed(run, f"lost the scheduler at {self.address} ({type(exc).__name__}: {exc})")
        except Exception as exc:  # noqa: BLE001 - anything the task raised on the worker fails this cell, not the grid
            return self._failed(run, f"the task failed on its worker ({type(exc).__name__}: {exc})")
        shutil.rmtree(run.out, ignore_errors=True)
        run.out.mkdir(parents=True)
        with tarfile.open(fileobj=io.BytesIO(cell.tar), mode="r") as tar:
            tar.extractall(run.out, filter="data")
        with open(run.out / RUN_LOG, "a") as log:
            log.write(f"(ran on {cell.host} via {self.address}, exit {cell.exit_code})\n")
        return cell.exit_code

    def _failed(self, run: GridRun, reason: str) -> int:
        run.out.mkdir(parents=True, exist_ok=True)
        (run.out / RUN_LOG).write_text(f"cluster {self.address}: {reason}\n")
        return 255

    async def close(self) -> None:
        """Disconnect from the scheduler (the cluster keeps running)."""
        await self.client.close()


async def connect(address: str, *, timeout_s: float = CONNECT_TIMEOUT_S) -> ClusterSession:
    """Connect to the scheduler at `address` and check its workers; raise ClusterError saying what is wrong."""
    import importlib.metadata

    from distributed import Client

    try:
        client = await Client(address, asynchronous=True, timeout=timeout_s, set_as_default=False)
    except (OSError, ValueError, TypeError, asyncio.TimeoutError) as exc:
        raise ClusterError(f"--cluster {address}: cannot reach a Dask scheduler there within {timeout_s:g} s "
                           f"({type(exc).__name__}: {exc})") from None
    try:
        workers = (await client.scheduler.identity(n_workers=-1))["workers"]
        if not workers:
            raise ClusterError(f"--cluster {address}: the scheduler has no workers; start some with "
                               f"`dask worker {address} --nthreads 1 --resources {RUN_RESOURCE}=1`")
        found = await client.run(importlib.metadata.version, "sidewalk-nav", on_error="return")
        lacking = sorted(w for w, v in found.items() if isinstance(v, BaseException))
        if lacking:
            raise ClusterError(f"--cluster {address}: worker(s) {', '.join(lacking)} lack the sidewalk package "
                               f"(pip install it in the worker's environment)")
        if any(RUN_RESOURCE in (w.get("resources") or {}) for w in workers.values()):
            resources: Optional[dict[str, int]] = {RUN_RESOURCE: 1}
        elif all(w.get("nthreads") == 1 for w in workers.values()):
            resources = None
        else:
            raise ClusterError(f"--cluster {address}: its workers would hold several runs at once; start them with "
                               f"`--nthreads 1` or `--resources {RUN_RESOURCE}=1`")
    except BaseException:
        await client.close()
        raise
    return ClusterSession(client, address, resources)
