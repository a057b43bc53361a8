"""A `sidewalk run` killed outright takes its children along (real processes, real Zenoh on loopback).

Its children live in sessions of their own, so only the parent-death signal armed at their start
(SIGKILL of the parent) or the launcher's SIGTERM handler (SIGTERM) can reach them.
"""

import asyncio
import contextlib
import os
import re
import signal
import sys

import psutil
import pytest

from sidewalk.health import collect_heartbeats
from tests._procs import wait_gone
from tests.sidewalk.test_e2e_faults import DATA
from wire.aio import Link
from wire.keys import ModuleKeys
from wire.network import NetworkConfig
from wire.ports import free_port

_ENDPOINT = re.compile(r"endpoint (tcp/[0-9.]+:[0-9]+)")


async def _endpoint(proc: asyncio.subprocess.Process, timeout: float) -> str:
    """Return the endpoint `sidewalk run` announces on stdout (its first progress line)."""
    assert proc.stdout is not None
    seen = []
    async with asyncio.timeout(timeout):
        while line := await proc.stdout.readline():
            seen.append(line.decode(errors="replace"))
            if m := _ENDPOINT.search(seen[-1]):
                return m.group(1)
    raise AssertionError(f"`sidewalk run` announced no endpoint: {''.join(seen)[-2000:]}")


async def _drain(proc: asyncio.subprocess.Process) -> None:
    assert proc.stdout is not None
    while await proc.stdout.read(65536):
        pass


def _described(pids: list[int]) -> list[str]:
    """Return each pid with its state and command line (which module was left, and doing what)."""
    out = []
    for pid in pids:
        try:
            p = psutil.Process(pid)
            out.append(f"{pid} {p.status()} {' '.join(p.cmdline())[:200]}")
        except psutil.Error:
            out.append(f"{pid} (gone)")
    return out


@pytest.mark.e2e
@pytest.mark.timeout(400)
@pytest.mark.parametrize(("arch", "last", "sig"), [("codger", "captain", signal.SIGKILL), ("eddie", "mission_service", signal.SIGTERM)])
async def test_a_killed_run_leaves_no_child_behind(tmp_path, arch, last, sig):
    ns = f"orphan{free_port()}"
    run = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "sidewalk", "run", "--arch", arch, "--mission", str(DATA / "short-hop.yaml"), "--rtf", "5",
        "--no-perception", "--no-record", "--ns", ns, "--out", str(tmp_path),
        stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT,
        env={**os.environ, "COLUMNS": "250"},
    )
    children: list[int] = []
    link = None
    try:
        endpoint = await _endpoint(run, 120)
        drain = asyncio.ensure_future(_drain(run))
        link = Link.open(NetworkConfig(namespace=ns, connect=(endpoint,)))
        # the module started last beats: every child was started and is up
        heard = await collect_heartbeats(link, ModuleKeys(ns), {last}, 300.0)
        assert last in heard, f"no heartbeat from {last}: heard {sorted(heard)}"
        children = [c.pid for c in psutil.Process(run.pid).children(recursive=True)]
        assert heard[last].beat.pid in children and len(children) >= 6, (children, heard[last].beat)
        os.kill(run.pid, sig)
        assert await run.wait() == -sig
        await drain
        left = await asyncio.to_thread(wait_gone, children, 30.0)
        if left:
            described = _described(left)
            for pid in left:  # the router prints its threads' stacks on SIGUSR1 (faulthandler), into its log
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGUSR1)
            await asyncio.to_thread(wait_gone, left, 2.0)
            logs = {p.name: p.read_text(errors="replace")[-3000:] for p in (tmp_path / "logs").glob("router*.log")}
            raise AssertionError(f"{arch} run killed by {signal.Signals(sig).name}: children left running: {described}\n{logs}")
    finally:
        if link is not None:
            link.close()
        if run.returncode is None:
            run.kill()
            await run.wait()
        for pid in children:  # never leave a process behind, whatever the test found
            try:
                os.killpg(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
