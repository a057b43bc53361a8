"""The parallel-vision facility: stripes that overlap by the operator's width, worker processes, frames in shared memory."""

from __future__ import annotations

import os

import numpy as np
import pytest

from modules.parallel import StripeOp, StripePlanError, VisionPool, WorkerError, aligned_for, partition
from tests.modules._stripe_ops import boom, box_sum, die_on_second, library_threads, squares

pytestmark = pytest.mark.timeout(180)  # quiet run ~6 s (worker start-up is most of it)


@pytest.mark.parametrize("length,parts,overlap,align", [(60, 10, 4, 1), (256, 3, 2, 1), (7, 4, 1, 1), (240, 4, 1, 4), (30, 8, 0, 8)])
def test_partition_cuts_cores_that_tile_the_image_and_halos_that_reach_the_overlap(length, parts, overlap, align) -> None:
    stripes = partition(length, parts, overlap, align)
    assert 1 <= len(stripes) <= parts
    assert stripes[0].core[0] == 0 and stripes[-1].core[1] == length
    for a, b in zip(stripes, stripes[1:]):
        assert a.core[1] == b.core[0] and a.core[1] % align == 0
    for s in stripes:
        assert s.core[1] > s.core[0]
        assert s.halo[0] == max(0, s.core[0] - overlap - (-overlap % align)) and s.halo[1] == min(length, s.core[1] + overlap + (-overlap % align))
    sizes = [s.core[1] - s.core[0] for s in stripes]
    assert max(sizes) - min(sizes) <= align  # near-equal shares


def test_alignment_makes_every_stripe_a_multiple_of_the_pixel_quantum() -> None:
    assert aligned_for(1, 256) == 1
    assert aligned_for(1, 86) == 32  # 86 px per row: 32 rows hold 2752 = 43 × 64 pixels
    assert aligned_for(4, 64) == 4
    with pytest.raises(StripePlanError):
        partition(0, 2)


@pytest.mark.parametrize("workers", [2, 3])
def test_a_local_operator_over_workers_equals_the_whole_image_bit_for_bit(workers: int) -> None:
    rng = np.random.default_rng(workers)
    img = rng.normal(100.0, 30.0, (97, 128)).astype(np.float32)  # an odd height: unequal stripes
    whole = box_sum({"img": img}, 5, None)["out"]
    with VisionPool(workers) as pool:
        got = pool.run(StripeOp(box_sum, overlap=2, axis=0), {"img": img}, {"out": (img.shape, np.float32)}, 5)["out"]
        assert np.array_equal(got, whole)
        cols = pool.run(StripeOp(box_sum, overlap=2, axis=1), {"img": img}, {"out": (img.shape, np.float32)}, 5)["out"]
        assert np.allclose(cols, whole, rtol=1e-5)  # running sums across the cut: equal to rounding
        # an overlap narrower than the operator: the pixels beside each cut are wrong
        short = pool.run(StripeOp(box_sum, overlap=1, axis=0), {"img": img}, {"out": (img.shape, np.float32)}, 5)["out"]
        assert not np.allclose(short, whole)
        bad_rows = np.flatnonzero(~np.isclose(short, whole).all(axis=1))
        cuts = [s.core[0] for s in pool.stripes(StripeOp(box_sum, overlap=1), {"img": img.shape})[1:]]
        assert all(min(abs(r - c) for c in cuts) <= 1 for r in bad_rows)


def test_a_pool_of_several_runs_each_process_with_one_library_thread_and_gives_the_caller_its_threads_back() -> None:
    import cv2

    cv2.setNumThreads(2)
    caller_before = library_threads([0], None)[0][1:]
    with VisionPool(2) as pool:
        got = pool.map(library_threads, [0, 1], None)
        assert {pid for pid, _, _ in got} - {os.getpid()}, "the second item ran in a worker"
        assert all(cv == 1 and set(blas) <= {1} for _, cv, blas in got), got
    assert library_threads([0], None)[0][1:] == caller_before
    with VisionPool(1) as own:  # one process: the libraries' own choice, unless asked
        assert own.map(library_threads, [0], None)[0][1] == 2
    with VisionPool(1, intra_threads=1) as own:
        assert own.map(library_threads, [0], None)[0][1] == 1
    assert cv2.getNumThreads() == 2
    with pytest.raises(StripePlanError, match="intra-operation threads"):
        VisionPool(2, intra_threads=0)


def test_map_keeps_the_order_and_uses_the_workers() -> None:
    with VisionPool(2) as pool:
        got = pool.map(squares, list(range(9)), 1)
    assert [v for v, _ in got] == [i * i + 1 for i in range(9)]
    assert {p for _, p in got} - {os.getpid()}, "the second chunk ran in a worker"


def test_a_failing_stripe_is_a_worker_error_naming_it_and_the_pool_serves_on() -> None:
    img = np.ones((64, 64), np.float32)
    with VisionPool(2) as pool:
        with pytest.raises(WorkerError, match="bad pixel in stripe 1"):
            pool.run(StripeOp(boom), {"img": img}, {"out": (img.shape, np.float32)})
        with pytest.raises(WorkerError, match=r"exited \(code 3\)"):
            pool.run(StripeOp(die_on_second), {"img": img}, {"out": (img.shape, np.float32)})
        again = pool.run(StripeOp(box_sum, overlap=1), {"img": img}, {"out": (img.shape, np.float32)}, 3)["out"]
        assert np.array_equal(again, box_sum({"img": img}, 3, None)["out"])  # the dead worker was replaced


def test_arrays_that_disagree_along_the_cut_are_refused_naming_them() -> None:
    with VisionPool(2) as pool:
        with pytest.raises(StripePlanError, match="'b'"):
            pool.run(StripeOp(box_sum), {"img": np.zeros((10, 4)), "b": np.zeros((12, 4))}, {"out": ((10, 4), np.float64)}, 3)
    with pytest.raises(StripePlanError, match="integer ≥ 1"):
        VisionPool(0)
