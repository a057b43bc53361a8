"""Child processes that die with their parent: Linux's parent-death signal, armed between fork and exec.

A run's children sit in sessions of their own (Ctrl-C in the terminal reaches only the launcher),
so a launcher killed outright (SIGKILL, a test's time-out) would leave them running: an orphaned
simulator and modules on a port. `die_with_parent()` gives `subprocess`/`asyncio` a `preexec_fn`
that asks the kernel to send the child SIGTERM when the thread that started it ends (the child
then shuts down as on any SIGTERM). Elsewhere than Linux it returns None: nothing armed.

A child that does not stop when asked is asked where it is stuck before it is killed: every process
of a run calls `dump_stacks_on_request()`, which makes `STACKS_SIGNAL` (SIGUSR1) print each of its
threads' stacks to its stderr (its log), even while its main thread is stuck in C (a Zenoh call);
`catches(pid, STACKS_SIGNAL)` tells a supervisor whether sending it is safe (uncaught, it kills).
"""

from __future__ import annotations

import ctypes
import faulthandler
import os
import signal
import sys
from typing import Callable, Optional

__all__ = ["STACKS_SIGNAL", "catches", "die_with_parent", "dump_stacks_on_request"]

#: the signal on which a process prints its threads' stacks (see `dump_stacks_on_request`)
STACKS_SIGNAL = signal.SIGUSR1

_PR_SET_PDEATHSIG = 1


def _load_prctl() -> Optional[Callable[..., int]]:
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


# resolved once here: between fork and exec the child must do as little as possible
_PRCTL = _load_prctl()


def die_with_parent(sig: int = signal.SIGTERM) -> Optional[Callable[[], None]]:
    """Return a `preexec_fn` making the child receive `sig` once this process's starting thread ends (None: unsupported).

    Call it on the thread that starts the child (the kernel ties the signal to that thread).
    """
    if _PRCTL is None:
        return None
    prctl, parent, signum = _PRCTL, os.getpid(), int(sig)

    def arm() -> None:
        prctl(_PR_SET_PDEATHSIG, signum, 0, 0, 0)
        if os.getppid() != parent:  # the parent died before the signal was armed: nobody would send it
            os.kill(os.getpid(), signum)

    return arm


def dump_stacks_on_request() -> None:
    """Print every thread's stack to stderr when this process receives `STACKS_SIGNAL` (idempotent)."""
    faulthandler.register(STACKS_SIGNAL, all_threads=True)


def catches(pid: int, sig: int) -> bool:
    """Return whether process `pid` has a handler for `sig` (Linux: /proc's SigCgt mask; elsewhere, or gone: False)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("SigCgt:"):
                    return bool(int(line.split()[1], 16) >> (int(sig) - 1) & 1)
    except (OSError, ValueError):
        pass
    return False
