"""The threads a process's libraries use inside one operation (OpenCV, BLAS, OpenMP), limited for a vision pool.

A pool partitions the work among processes, as the Warp among its cells. Each process's libraries
may also split one operation over threads of their own (OpenCV's `parallel_for`, OpenBLAS in a
matrix product): N processes each with as many threads as cores oversubscribe the cores, and a
single process using them is no longer one cell. So a pool of several workers runs each of its
processes with `intra_threads` such threads (one by default), the caller's for the pool's life; the
benchmark compares one worker and several alike (`bench/parallel.py`). The numba kernels here are
not parallel (no `parallel=True`): nothing to limit there.
"""

from __future__ import annotations

from typing import Callable

__all__ = ["limit_intra_threads"]


def limit_intra_threads(n: int) -> Callable[[], None]:
    """Limit this process's libraries to `n` threads per operation; return a function that restores what was set before."""
    import cv2
    from threadpoolctl import threadpool_limits

    if n < 1:
        raise ValueError(f"intra-operation threads: expected ≥ 1, got {n}")
    undo: list[Callable[[], None]] = []
    before_cv = cv2.getNumThreads()
    cv2.setNumThreads(n)
    undo.append(lambda: cv2.setNumThreads(before_cv))
    limits = threadpool_limits(limits=n)  # BLAS and OpenMP pools loaded now (numpy's, OpenCV's own OpenBLAS)
    undo.append(limits.restore_original_limits)
    def restore() -> None:
        for u in reversed(undo):
            u()

    return restore
