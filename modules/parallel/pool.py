"""The vision pool: run stripe operators (and chunks of work) over N worker processes, frames in shared memory.

`VisionPool(workers)` is the caller's process plus `workers − 1` spawned worker processes (the
Warp's cells); with one worker nothing is spawned and an operator runs on the whole image in the
caller, exactly as the single-process code. `run(op, inputs, outputs)` copies the inputs once into
the shared frame, cuts them into `workers` stripes overlapping by the operator's width
(`stripes.partition`), has each worker run the operator on its stripe — the caller takes the first —
and returns the assembled outputs. `map(fn, items)` splits a list into contiguous chunks the same way
(features among cells, as FIDO's correlation was). `share` places arrays in the shared frame, and
`post` / `collect` send one worker a task over them and take the answers as they come (what
`frames.run_frames` schedules whole frames with). Workers start with the pool and live until
`close()` (or the end of the `with` block, or the caller's exit).
"""

from __future__ import annotations

import multiprocessing as mp
import time
import weakref
from collections import deque
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from modules.parallel.errors import StripePlanError, WorkerError
from modules.parallel.intra_threads import limit_intra_threads
from modules.parallel.shared_frame import ArrayRef, SharedFrame
from modules.parallel.stripe_op import StripeOp, pixels_per_unit, run_stripe, stripe_length
from modules.parallel.stripes import Stripe, aligned_for, partition
from modules.parallel.worker import serve

__all__ = ["VisionPool"]

#: One output: its shape and dtype.
OutputSpec = tuple[tuple[int, ...], Any]


class _Worker:
    """One spawned worker process and the host's end of its pipe."""

    def __init__(self, ctx, index: int, warm: Sequence[str], intra_threads: int | None = None) -> None:
        self.index = index
        self.conn, child = ctx.Pipe(duplex=True)
        self.proc = ctx.Process(target=serve, args=(child, tuple(warm), intra_threads), name=f"vision-worker-{index}", daemon=True)
        self.proc.start()
        child.close()
        self.ready = False

    def wait_ready(self, timeout: float) -> None:
        if self.ready:
            return
        if not self.conn.poll(timeout):
            raise WorkerError(f"vision worker {self.index} (pid {self.proc.pid}) did not start within {timeout:g} s")
        self.reply("start-up")
        self.ready = True

    def send(self, msg: tuple) -> None:
        try:
            self.conn.send(msg)
        except (BrokenPipeError, OSError):
            raise WorkerError(f"vision worker {self.index} (pid {self.proc.pid}) is gone (exit code {self.proc.exitcode})") from None

    def reply(self, what: str, timeout: float | None = None) -> Any:
        if timeout is not None and not self.conn.poll(timeout):
            raise WorkerError(f"vision worker {self.index} (pid {self.proc.pid}): no answer on {what} within {timeout:g} s")
        try:
            kind, value = self.conn.recv()
        except (EOFError, OSError):
            self.proc.join(1.0)
            raise WorkerError(f"vision worker {self.index} (pid {self.proc.pid}) exited (code {self.proc.exitcode}) on {what}") from None
        if kind == "error":
            raise WorkerError(f"vision worker {self.index} on {what}: {value}")
        return value

    def stop(self, timeout: float = 2.0) -> None:
        try:
            self.conn.send(None)
        except (BrokenPipeError, OSError):
            pass
        self.proc.join(timeout)
        if self.proc.is_alive():
            self.proc.terminate()
            self.proc.join(timeout)
        self.conn.close()


def _shutdown(workers: list[_Worker], frame: list[SharedFrame | None], restore: list[Callable[[], None]]) -> None:
    while restore:
        restore.pop()()
    for w in workers:
        w.stop()
    workers.clear()
    if frame[0] is not None:
        frame[0].close()
        frame[0] = None


class VisionPool:
    """Run stripe operators over `workers` processes (the caller included); see the module docstring."""

    def __init__(self, workers: int = 1, *, warm: Sequence[str] = (), start_timeout_s: float = 120.0,
                 task_timeout_s: float = 120.0, intra_threads: int | None = None) -> None:
        """Start `workers − 1` worker processes importing `warm` modules; time-outs [s] wall for start-up and for one call.

        `intra_threads`: the threads each of the pool's processes (the caller's for the pool's life) lets its
        libraries use inside one operation (`modules.parallel.intra_threads`); None: one with several workers,
        the libraries' own choice with one.
        """
        if not isinstance(workers, int) or workers < 1:
            raise StripePlanError(f"vision workers: expected an integer ≥ 1, got {workers!r}")
        if intra_threads is not None and (not isinstance(intra_threads, int) or intra_threads < 1):
            raise StripePlanError(f"intra-operation threads: expected an integer ≥ 1, got {intra_threads!r}")
        self.workers = workers
        self.start_timeout_s = start_timeout_s
        self.task_timeout_s = task_timeout_s
        self.intra_threads = intra_threads if intra_threads is not None else (1 if workers > 1 else None)
        self._warm = tuple(warm)
        self._ctx = mp.get_context("spawn")  # never fork: the caller may hold Zenoh's threads
        self._restore: list[Callable[[], None]] = [] if self.intra_threads is None else [limit_intra_threads(self.intra_threads)]
        self._procs: list[_Worker] = [_Worker(self._ctx, i + 1, self._warm, self.intra_threads) for i in range(workers - 1)]
        self._frame: list[SharedFrame | None] = [SharedFrame() if workers > 1 else None]
        self._posted: dict[int, deque[str]] = {}  # worker index → what its unanswered tasks are, oldest first
        self._finalizer = weakref.finalize(self, _shutdown, self._procs, self._frame, self._restore)

    # ---- life ------------------------------------------------------------------------------------
    def __enter__(self) -> "VisionPool":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop the workers and remove the shared frame (idempotent)."""
        self._finalizer()

    def wait_ready(self) -> None:
        """Block until every worker has started (imported its modules); WorkerError after the start time-out."""
        deadline = time.monotonic() + self.start_timeout_s
        for w in self._live():
            w.wait_ready(max(0.0, deadline - time.monotonic()))

    def _live(self) -> list[_Worker]:
        """Return the workers, replacing any that died since the last call (not one with unanswered tasks: `collect` reports it)."""
        if not self._finalizer.alive:
            raise WorkerError("vision pool: used after close()")
        for i, w in enumerate(self._procs):
            if not w.proc.is_alive() and not self._posted.get(w.index):
                w.stop(0.1)
                self._procs[i] = _Worker(self._ctx, w.index, self._warm, self.intra_threads)
        return self._procs

    # ---- work ------------------------------------------------------------------------------------
    def stripes(self, op: StripeOp, shapes: Mapping[str, tuple[int, ...]]) -> tuple[Stripe, ...]:
        """Return how `run` would cut arrays of these shapes for `op` on this pool."""
        length = stripe_length(op, shapes)
        align = aligned_for(op.align, pixels_per_unit(op, shapes))
        return partition(length, self.workers, op.overlap, align)

    def run(self, op: StripeOp, inputs: Mapping[str, np.ndarray], outputs: Mapping[str, OutputSpec], params: Any = None) -> dict[str, np.ndarray]:
        """Run `op` over the stripes of `inputs`; return the `outputs` (name → (shape, dtype)) assembled from the cores."""
        inputs = {k: np.asarray(v) for k, v in inputs.items()}
        shapes = {**{k: v.shape for k, v in inputs.items()}, **{k: tuple(s) for k, (s, _) in outputs.items()}}
        stripes = self.stripes(op, shapes)
        if len(stripes) == 1:
            got = op.fn({k: v for k, v in inputs.items()}, params, stripes[0])
            missing = [k for k in outputs if k not in got]
            if missing:
                raise StripePlanError(f"stripe operator {op.fn.__name__}: returned no {missing[0]!r}")
            return {k: np.asarray(got[k]) for k in outputs}
        self._idle(op.fn.__name__)
        live = self._live()
        frame = self._frame[0]
        assert frame is not None
        refs = frame.place(inputs, outputs)
        in_refs = {k: refs[k] for k in inputs}
        out_refs = {k: refs[k] for k in outputs}
        busy = []
        for s in stripes[1:]:
            w = live[s.index - 1]
            w.wait_ready(self.start_timeout_s)
            w.send(("stripe", op, frame.name, in_refs, out_refs, params, s))
            busy.append((w, s))
        err: Exception | None = None
        try:
            run_stripe(op, inputs, {k: frame.array(k) for k in outputs}, params, stripes[0])
        except Exception as exc:  # the workers' replies must still be read before the next call
            err = exc
        for w, s in busy:
            try:
                w.reply(f"{op.fn.__name__} stripe {s.index} {s.core}", self.task_timeout_s)
            except WorkerError as exc:
                err = err or exc
        if err is not None:
            raise err
        return {k: frame.array(k).copy() for k in outputs}

    def map(self, fn: Callable[[list, Any], list], items: Sequence[Any], params: Any = None) -> list:
        """Return fn(items, params) computed as `workers` contiguous chunks in parallel (fn is module-level; items pickled)."""
        items = list(items)
        if self.workers == 1 or len(items) < 2:
            return list(fn(items, params))
        n = min(self.workers, len(items))
        cuts = [len(items) * i // n for i in range(n + 1)]
        self._idle(fn.__name__)
        live = self._live()
        busy = []
        for i in range(1, n):
            w = live[i - 1]
            w.wait_ready(self.start_timeout_s)
            w.send(("chunk", fn, items[cuts[i]:cuts[i + 1]], params))
            busy.append(w)
        err: Exception | None = None
        out: list = []
        try:
            out = list(fn(items[cuts[0]:cuts[1]], params))
        except Exception as exc:
            err = exc
        for w in busy:
            try:
                out += list(w.reply(f"{fn.__name__} chunk", self.task_timeout_s))
            except WorkerError as exc:
                err = err or exc
        if err is not None:
            raise err
        return out

    # ---- tasks: one worker at a time, answers as they come ------------------------------------------
    def _idle(self, what: str) -> None:
        if any(self._posted.values()):
            raise StripePlanError(f"vision pool: {what} asked while posted tasks are unanswered (collect or drain them first)")

    def share(self, arrays: Mapping[str, np.ndarray], outputs: Mapping[str, OutputSpec]) -> dict[str, ArrayRef]:
        """Copy `arrays` into the shared frame and reserve `outputs` (name → (shape, dtype)); return every array's ref.

        The refs hold until the next `share` or `run`; StripePlanError on a one-worker pool (it has no shared frame).
        """
        self._idle("share")
        frame = self._frame[0]
        if frame is None:
            raise StripePlanError("vision pool: one worker has no shared frame")
        return frame.place({k: np.asarray(v) for k, v in arrays.items()}, outputs)

    def views(self, refs: Mapping[str, ArrayRef]) -> dict[str, np.ndarray]:
        """Return the shared arrays `refs` names as views of the shared frame (this process's own)."""
        frame = self._frame[0]
        if frame is None:
            raise StripePlanError("vision pool: one worker has no shared frame")
        return {k: frame.view(r) for k, r in refs.items()}

    def post(self, worker: int, fn: Callable[[Mapping[str, np.ndarray], Any], Any], refs: Mapping[str, ArrayRef], args: Any, what: str) -> None:
        """Send worker `worker` (1 … workers − 1) the task fn(views of `refs`, args); `what` names it in errors and in `collect`."""
        if not 1 <= worker < self.workers:
            raise StripePlanError(f"vision pool: no worker {worker} among {self.workers - 1}")
        frame = self._frame[0]
        assert frame is not None
        w = self._live()[worker - 1]  # a worker that died while idle is replaced
        w.wait_ready(self.start_timeout_s)
        w.send(("task", fn, frame.name, dict(refs), args))
        self._posted.setdefault(worker, deque()).append(what)

    def unanswered(self) -> int:
        """Return how many posted tasks have not been answered yet."""
        return sum(len(q) for q in self._posted.values())

    def collect(self, timeout_s: float | None = None) -> tuple[int, str, Any] | None:
        """Return the next answer to a posted task as (worker, what, value), waiting up to `timeout_s` [s] wall
        (default: the task time-out; None back only when `timeout_s` is given). WorkerError when a worker
        failed or is gone, or when no answer comes within the task time-out."""
        busy = {self._procs[i - 1].conn: i for i, q in self._posted.items() if q}
        if not busy:
            raise StripePlanError("vision pool: collect with no task posted")
        limit = self.task_timeout_s if timeout_s is None else timeout_s
        ready = wait(list(busy), limit)
        if not ready:
            if timeout_s is not None:
                return None
            names = ", ".join(f"worker {i}: {q[0]}" for i, q in self._posted.items() if q)
            raise WorkerError(f"vision pool: no answer within {limit:g} s ({names})")
        i = busy[ready[0]]
        what = self._posted[i].popleft()
        return i, what, self._procs[i - 1].reply(what)

    def drain(self) -> None:
        """Read and drop every unanswered posted task's answer (after a failure), so the pool can be used again."""
        for i, q in self._posted.items():
            w = self._procs[i - 1]
            while q:
                what = q.popleft()
                try:
                    w.reply(what, self.task_timeout_s)
                except WorkerError:
                    q.clear()  # a dead or stuck worker answers nothing more: end it, `_live` replaces it
                    if w.proc.is_alive():
                        w.proc.terminate()
                        w.proc.join(self.start_timeout_s)
