"""Start and stop real OS processes for end-to-end tests, synchronised on a ready line."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import tempfile
import time
from pathlib import Path

__all__ = ["ROOT", "SPAWN_TIMEOUT_S", "spawn", "stop"]

ROOT = Path(__file__).resolve().parents[2]

#: how long [s wall] a starting process may take to print its ready line: a process that exits is noticed at once,
#: so this bounds only a slow start. Sized like the supervisor's `READY_TIMEOUT_S` (the simulator took 121 s on a
#: 2-core machine at a load of 30, numba and all); the old 60 s failed at loads above 20.
SPAWN_TIMEOUT_S = 300.0


def spawn(args: list[str], ready: str, timeout: float = SPAWN_TIMEOUT_S) -> subprocess.Popen:
    """Start a process and return once a stdout line contains `ready` (wall timeout [s]).

    stderr goes to an unnamed temporary file (never a pipe nobody drains); it is shown on failure, with the
    exit code of a process that died or the load average of one that was only slow.
    """
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    err = tempfile.TemporaryFile()
    p = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.PIPE, stderr=err, text=True, env=env)
    p.err_file = err  # type: ignore[attr-defined]
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        r, _, _ = select.select([p.stdout], [], [], max(0.0, deadline - time.monotonic()))
        if not r:
            break
        line = p.stdout.readline()
        if not line:  # stdout closed: the process is ending; let it, so its exit code can be told
            try:
                p.wait(5)
            except subprocess.TimeoutExpired:
                pass
            break
        if ready in line:
            return p
    code = p.poll()
    p.kill()
    p.wait(10)
    err.seek(0)
    why = (f"exited with code {code} before it was ready" if code is not None
           else f"printed no ready line within {timeout:.0f} s (load average {os.getloadavg()[0]:.1f})")
    raise AssertionError(f"{args[:4]} {why}: {err.read()[-2000:].decode(errors='replace')}")


def stop(p: subprocess.Popen) -> int:
    """SIGTERM a process, SIGKILL it after 15 s; close its pipes; return the exit code."""
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(5)
    p.stdout.close()
    p.err_file.close()
    return p.returncode
