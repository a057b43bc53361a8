"""Start and stop real OS processes for end-to-end tests, synchronised on a ready line."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import tempfile
import time
from pathlib import Path

__all__ = ["ROOT", "spawn", "stop"]

ROOT = Path(__file__).resolve().parents[2]


def spawn(args: list[str], ready: str, timeout: float = 60.0) -> subprocess.Popen:
    """Start a process and return once a stdout line contains `ready` (wall timeout [s]).

    stderr goes to an unnamed temporary file (never a pipe nobody drains); it is shown on failure.
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
        if not line:
            break
        if ready in line:
            return p
    p.kill()
    p.wait(10)
    err.seek(0)
    raise AssertionError(f"{args[:4]} not ready: {err.read()[-2000:].decode(errors='replace')}")


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
