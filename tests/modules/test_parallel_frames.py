"""Frame partitioning (`modules.parallel.frames`): whole frames among workers, the state-carrying step in the caller, in order."""

from __future__ import annotations

import os

import numpy as np
import pytest

from modules.parallel import Frame, VisionPool, WorkerError, run_frames
from tests.modules._frame_stages import STAGES, sequential, step_state

pytestmark = pytest.mark.timeout(120)  # quiet run ~8 s (worker start-up is most of it; the hung worker's 2 s time-out)


def _run(pool: VisionPool, xs: list[np.ndarray], faults: dict[int, str] | None = None) -> list:
    frames = [Frame({"x": x}, {"s": ((1,), np.float64)}) for x in xs]
    return run_frames(pool, STAGES, frames, lambda k: (k, (faults or {}).get(k, ""), os.getpid()), step_state([0.0]))


@pytest.mark.parametrize("workers", [2, 3])
def test_frames_over_workers_give_the_one_after_the_other_results_in_order(workers: int) -> None:
    rng = np.random.default_rng(workers)
    xs = [rng.normal(0.0, 1.0 + k, 50 + 7 * k) for k in range(15)]  # unequal frames
    with VisionPool(workers) as pool:
        got = _run(pool, xs)
        again = _run(pool, xs[::-1])  # the shared frame reused; the step's state starts afresh
    assert [v for v, _ in got] == sequential(xs)
    assert [v for v, _ in again] == sequential(xs[::-1])
    assert sequential(xs) != sequential(xs[::-1])  # the step's order shows in the results
    # the first `depth` frames go to each worker in turn; whether the caller takes some depends on timing
    assert len({p for _, p in got} - {os.getpid()}) == workers - 1, "every worker ran some frames"


def test_a_failing_or_dying_worker_is_a_worker_error_and_the_pool_serves_on() -> None:
    xs = [np.arange(10.0) + k for k in range(8)]
    with VisionPool(2, task_timeout_s=2.0) as pool:
        # frame 1 always goes to worker 1: the first `depth` frames are the workers'
        with pytest.raises(WorkerError, match="bad frame 1"):
            _run(pool, xs, {1: "raise"})
        with pytest.raises(WorkerError, match=r"exited \(code 4\)"):
            _run(pool, xs, {1: "exit"})
        with pytest.raises(WorkerError, match="no answer within 2 s"):
            _run(pool, xs, {1: "hang"})
        assert [v for v, _ in _run(pool, xs)] == sequential(xs)  # dead and stuck workers replaced


def test_one_worker_runs_every_stage_in_the_caller_in_order() -> None:
    xs = [np.arange(5.0) * k - 3.0 for k in range(6)]
    with VisionPool(1) as pool:
        got = _run(pool, xs, {1: "exit"})  # faults strike only in workers: none here
    assert [v for v, _ in got] == sequential(xs)
    assert {p for _, p in got} == {os.getpid()}
