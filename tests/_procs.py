"""Process helpers for tests: wait, on /proc with a deadline, until a signal really took effect."""

from __future__ import annotations

import os
import time
from pathlib import Path

__all__ = ["wait_stopped", "wait_gone"]


def _states(pid: int) -> list[str]:
    """Return the state letter of every thread of `pid` (empty once it is gone or reaped)."""
    out = []
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except FileNotFoundError:
        return out
    for tid in tasks:
        try:
            stat = Path(f"/proc/{pid}/task/{tid}/stat").read_text()
        except (FileNotFoundError, ProcessLookupError):
            continue
        out.append(stat[stat.rindex(")") + 2])
    return out


def wait_stopped(pid: int, timeout: float = 10.0) -> None:
    """Return once every thread of `pid` is stopped (state T); AssertionError after `timeout` wall [s].

    `kill(SIGSTOP)` returns before the stop takes effect: one thread takes the signal and stops the
    others when it next runs, so on a loaded machine the rest of the process works on meanwhile.
    """
    end = time.monotonic() + timeout
    while True:
        states = _states(pid)
        if states and all(s == "T" for s in states):
            return
        assert time.monotonic() < end, f"pid {pid} not stopped within {timeout} s: thread states {states}"
        time.sleep(0.005)  # polling /proc: the kernel offers no event for another process's stop


def wait_gone(pids: list[int], timeout: float = 20.0) -> list[int]:
    """Return the pids still running (not gone, not zombies) after waiting up to `timeout` wall [s] for all to end."""
    end = time.monotonic() + timeout
    while True:
        left = [p for p in pids if any(s not in ("Z", "X") for s in _states(p))]
        if not left or time.monotonic() >= end:
            return left
        time.sleep(0.05)  # polling /proc with a deadline: no event tells of a non-child's exit
