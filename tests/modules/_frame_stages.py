"""A toy cycle for the frame-partitioning tests (module level: spawned workers import it by name).

Each frame is a vector `x` in the shared frame; the head keeps x² and hands the step x's sum; the
step carries a state from frame to frame (s ← s / 2 + sum, so frame order matters) and leaves it in
the frame's `s`; the tail returns x² · s and the process that ran it. `args` of a head: (frame
index, fault), where fault says what goes wrong on that frame in a worker: "raise", "exit" or "hang".
"""

from __future__ import annotations

import os
import threading

import numpy as np

from modules.parallel import FrameStages

__all__ = ["STAGES", "step_state", "sequential"]


def _head(arrays, args):
    k, fault, host = args
    if os.getpid() != host:
        if fault == "raise":
            raise ValueError(f"bad frame {k}")
        if fault == "exit":
            os._exit(4)
        if fault == "hang":
            threading.Event().wait()  # never set: a worker that stops answering
    x = arrays["x"]
    return x * x, float(x.sum())


def _tail(arrays, kept, _):
    return float(kept @ np.full_like(kept, arrays["s"][0])), os.getpid()


STAGES = FrameStages(_head, _tail)


def step_state(state: list[float]):
    """Return the step of a run; `state` holds s across frames."""
    def step(k: int, total: float, arrays) -> None:
        state[0] = state[0] / 2 + total
        arrays["s"][0] = state[0]
    return step


def sequential(xs: list[np.ndarray]) -> list[float]:
    """Return the tails' results of the frames run one after the other in one process."""
    s, out = 0.0, []
    for x in xs:
        kept, total = x * x, float(x.sum())
        s = s / 2 + total
        out.append(float(kept @ np.full_like(kept, s)))
    return out
