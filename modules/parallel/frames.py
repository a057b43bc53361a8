"""Frame partitioning: whole frames among the vision workers, the one stage that carries state in the caller, in frame order.

Input partitioning as the Warp's programs used it — "each cell performed the complete algorithm on a
portion of the data" (Navlab 1990 §4.3.2.2) — with frames for the portions, for a cycle whose work
is mostly not per pixel (patches, objects, a pose fit) and so does not split into image stripes.
A cycle is cut in three (`FrameStages`): a `head` that depends on its frame alone, a `step` that
carries state from frame to frame (it must see the frames in order, so the caller runs it), and a
`tail` that depends on its frame and on what the step gave it. Head and tail of a frame run in the
same process (what the head keeps for the tail stays there); frames go to the workers in order,
each holding at most `depth` unfinished frames, and the caller takes the next frame itself whenever
it has nothing else to do. Every stage is the same code in one process, in whatever process it
runs, so the results are those of the frames run one after the other.

`run_frames` measures throughput, not latency: frames overlap in time, and each frame takes as
long as it did alone.
"""

from __future__ import annotations

import itertools
import os
import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from modules.parallel.pool import OutputSpec, VisionPool

__all__ = ["Frame", "FrameStages", "run_frames"]

#: head(frame's shared arrays, args) → (kept for the tail, value for the step); module-level.
HeadFn = Callable[[Mapping[str, np.ndarray], Any], tuple[Any, Any]]
#: tail(frame's shared arrays, kept, step's value) → the frame's result; module-level.
TailFn = Callable[[Mapping[str, np.ndarray], Any, Any], Any]


@dataclass(frozen=True)
class FrameStages:
    """A per-frame cycle cut where state passes between frames: `head` and `tail` module-level (workers import them)."""

    head: HeadFn
    tail: TailFn


@dataclass(frozen=True)
class Frame:
    """One frame of a run: its `inputs` (name → array) and the `outputs` its stages pass on (name → (shape, dtype))."""

    inputs: Mapping[str, np.ndarray]
    outputs: Mapping[str, OutputSpec]


#: What heads keep for their tails in this process: (batch, frame) → kept.
_KEPT: dict[tuple[str, int], Any] = {}
_BATCHES = itertools.count()


def _head_task(arrays: Mapping[str, np.ndarray], args: tuple) -> tuple[Any, float]:
    """Run a head, keep what it keeps here; return its value for the step and its time [s]."""
    fn, key, a = args
    t0 = time.perf_counter()
    for stale in [k for k in _KEPT if k[0] != key[0]]:  # left by a batch that failed
        del _KEPT[stale]
    kept, value = fn(arrays, a)
    _KEPT[key] = kept
    return value, time.perf_counter() - t0


def _tail_task(arrays: Mapping[str, np.ndarray], args: tuple) -> tuple[Any, float]:
    """Run a tail on what its head kept here; return the frame's result and the tail's time [s]."""
    fn, key, value = args
    t0 = time.perf_counter()
    return fn(arrays, _KEPT.pop(key), value), time.perf_counter() - t0


def run_frames(pool: VisionPool, stages: FrameStages, frames: Sequence[Frame], head_args: Callable[[int], Any],
               step: Callable[[int, Any, Mapping[str, np.ndarray]], Any], depth: int = 4,
               gather: Callable[[int, Any, Mapping[str, np.ndarray]], Any] | None = None) -> list:
    """Run every frame's head, step and tail; return the tails' results in frame order.

    `head_args(k)` gives frame k's head its args; it runs here, in frame order, as frame k is handed out.
    Every stage of frame k sees its inputs and outputs (zeroed) by name, in the pool's shared frame
    (the inputs copied there once, when the frame is handed out; with one worker, in this process).
    `step(k, head's value, frame k's arrays)` runs in the caller, for k = 0, 1, … in order, and
    returns the value for frame k's tail. Each worker holds up to `depth` unfinished frames; the
    caller takes the next frame itself when it would otherwise wait and has less work than every
    worker: its time so far, all but the waiting, and the steps and tails it has still to run, against
    the frames a worker has been given at the cost measured so far (before the first frame is
    measured, it takes one). `gather(k, tail's result, frame k's arrays)`, run here once every frame
    is done, returns what comes back for frame k (results that left arrays in the shared frame
    collect them). With one worker every stage runs here, frame after frame. A failed stage or
    worker raises (a worker's as WorkerError) once the other workers' answers are read.
    """
    n = len(frames)
    batch = f"{os.getpid()}.{next(_BATCHES)}"
    results: list[Any] = [None] * n
    load = {w: 0 for w in range(1, pool.workers)}  # unfinished frames per worker
    given = {w: 0 for w in load}  # frames given to each worker
    owner: list[int] = [0] * n
    heads: dict[int, Any] = {}  # frame → head's value, ready for the step
    own_tails: deque[tuple[int, Any]] = deque()  # the caller's frames whose step is done
    spent = [0.0] * n  # head and tail time of each frame [s]
    measured: list[float] = []  # time of each finished frame [s]
    mine = 0  # frames the caller took
    steps_s = 0.0  # the caller's time in steps [s]
    start, waited = time.perf_counter(), 0.0  # the caller's time waiting for workers [s]
    to_post: dict[int, list[tuple[str, int, tuple]]] = {w: [] for w in load}  # each worker's tasks not yet sent
    flying = {w: 0 for w in load}  # each worker's tasks sent, not answered
    done = assigned = stepped = started = 0  # started: heads begun

    if pool.workers > 1:  # room for every frame at once; a frame's inputs are copied in when it is handed out
        refs = pool.share({}, {f"{k}.{a}": spec for k, f in enumerate(frames)
                               for a, spec in (*((a, (v.shape, v.dtype)) for a, v in f.inputs.items()), *f.outputs.items())})
        shared = [{a: refs[f"{k}.{a}"] for a in (*f.inputs, *f.outputs)} for k, f in enumerate(frames)]
    else:
        local = [{**f.inputs, **{a: np.zeros(shape, dtype) for a, (shape, dtype) in f.outputs.items()}} for f in frames]

    def views(k: int) -> Mapping[str, np.ndarray]:
        return pool.views(shared[k]) if pool.workers > 1 else local[k]

    def hand_out(k: int) -> None:
        if pool.workers > 1:
            arrays = views(k)
            for a, v in frames[k].inputs.items():
                np.copyto(arrays[a], v, casting="no")
            for a in frames[k].outputs:
                arrays[a].fill(0)

    def finish(k: int, value: Any, seconds: float) -> None:
        nonlocal done
        results[k] = value
        spent[k] += seconds
        measured.append(spent[k])
        done += 1

    def dispatch() -> None:
        """Keep each worker at two tasks in flight, heads first while fewer than two frames are headed ahead of the step."""
        nonlocal started
        for w, todo in to_post.items():
            while flying[w] < 2 and todo:
                heads_next = [t for t in todo if t[0] == "head"]
                tails_next = [t for t in todo if t[0] == "tail"]
                task = heads_next[0] if heads_next and (not tails_next or started - stepped < 2) else (tails_next or heads_next)[0]
                todo.remove(task)
                kind, k, args = task
                pool.post(w, _head_task if kind == "head" else _tail_task, shared[k], args, f"{kind} {k}")
                flying[w] += 1
                started += kind == "head"

    def answer(w: int, what: str, got: tuple[Any, float]) -> None:
        flying[w] -= 1
        kind, k = what.split(" ")
        value, seconds = got
        if kind == "head":
            heads[int(k)] = value
            spent[int(k)] += seconds
        else:
            finish(int(k), value, seconds)
            load[w] -= 1

    def caller_takes() -> bool:
        if assigned >= n:
            return False
        if not load:
            return True
        if not measured:
            return mine == 0  # one frame while the workers' first heads run: then a frame's cost is known
        cost = sum(measured) / len(measured)
        # the caller's work so far (everything but waiting), its steps to come and its frames' tails to come,
        # against the frames the least loaded worker has been given
        busy = time.perf_counter() - start - waited
        to_come = (n - stepped) * steps_s / max(stepped, 1) + sum(owner[k] == 0 and results[k] is None for k in range(assigned)) * cost / 2
        return busy + to_come <= min(given.values()) * cost

    try:
        while done < n:
            for w in load:  # hand frames out in order: arguments drawn, inputs copied in
                while load[w] < depth and assigned < n:
                    hand_out(assigned)
                    to_post[w].append(("head", assigned, (stages.head, (batch, assigned), head_args(assigned))))
                    owner[assigned] = w
                    load[w] += 1
                    given[w] += 1
                    assigned += 1
            while pool.unanswered() and (got := pool.collect(0.0)) is not None:
                answer(*got)
            dispatch()
            if stepped < n and stepped in heads:
                k = stepped
                t0 = time.perf_counter()
                value = step(k, heads.pop(k), views(k))
                steps_s += time.perf_counter() - t0
                stepped += 1
                if owner[k] == 0:
                    own_tails.append((k, value))
                else:
                    to_post[owner[k]].append(("tail", k, (stages.tail, (batch, k), value)))
            elif own_tails:
                k, value = own_tails.popleft()
                finish(k, *_tail_task(views(k), (stages.tail, (batch, k), value)))
            elif caller_takes():  # the caller would wait: it takes the next frame itself
                k = assigned
                assigned += 1
                mine += 1
                hand_out(k)
                started += 1
                heads[k], spent[k] = _head_task(views(k), (stages.head, (batch, k), head_args(k)))
            elif done < n:
                t0 = time.perf_counter()
                answer(*pool.collect())
                waited += time.perf_counter() - t0
    except BaseException:
        pool.drain()
        raise
    finally:
        for k in [k for k in _KEPT if k[0] == batch]:
            del _KEPT[k]
    return results if gather is None else [gather(k, r, views(k)) for k, r in enumerate(results)]
