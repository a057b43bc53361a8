"""PERCEPTION over vision workers: the same registration, patches, objects and fix as one process, bit for bit, on simulator frames."""

from __future__ import annotations

import numpy as np
import pytest

from modules.parallel import VisionPool
from modules.perception.frame_cycles import FrameJob, process_frames
from modules.perception.monitor import ResolutionTable
from modules.perception.patch_maker import Segmentation
from modules.perception.pipeline import PerceptionPipeline, PipelineOutput
from modules.perception.sensor_frame import colored_range_image
from sidewalk.cli._perception import FrameSource, eval_frames

pytestmark = pytest.mark.timeout(300)  # quiet run ~25 s (frames, worker start-up, 8 cycles three times)


def _digest(out: PipelineOutput) -> tuple:
    cal = out.calibration
    return (out.method, out.segmented.labels.tobytes(), out.segmented.patches.ids.tobytes(),
            tuple((p.polygon, p.edge_flags, p.colour_type, p.surface, p.neighbours) for p in out.segmented.patches.patches),
            tuple((f.predicted.obj.object_id, tuple(p.id for p in f.patches)) for f in out.found),
            None if out.navigable is None else out.navigable.wkb,
            None if cal is None else (cal.pose, cal.covariance.tobytes(), cal.kind), out.failure, out.fix_note)


def _run(frames, table: ResolutionTable, pool: VisionPool | None) -> list[tuple]:
    pipe = PerceptionPipeline(ResolutionTable(table.sensor, max_distance=table.max_distance), pool=pool)
    got = []
    for fr in frames:
        img = colored_range_image(fr.sensor, pool=pool)
        got.append((tuple(a.tobytes() for a in (img.xyz, img.ground_xy, img.range_m, img.valid, img.rgb)),
                    _digest(pipe.process(img, fr.objects, fr.prior_pose, error_allowance=1.0, step=1))))
    return got


def test_two_and_three_workers_give_what_one_process_gives() -> None:
    src = FrameSource("campus", seed=3)
    frames = list(eval_frames(src, 8, np.random.default_rng(3), (0.5, 2.0)))  # half on the slope and stairs (colored range)
    alone = _run(frames, src.table, None)
    methods = {d[0] for _, d in alone}
    assert {Segmentation.COLOUR, Segmentation.COLORED_RANGE} <= methods, methods
    assert sum(d[6] is not None for _, d in alone) >= 4  # frames with a fix: the comparison covers the whole cycle
    for workers in (2, 3):
        with VisionPool(workers, warm=("modules.perception",)) as pool:
            assert _run(frames, src.table, pool) == alone, f"{workers} workers differ from one process"


@pytest.mark.timeout(300)  # quiet run ~20 s (frames, worker start-up, 12 cycles four times)
def test_frames_over_two_and_three_workers_give_what_one_process_gives() -> None:
    """`process_frames`: whole frames among the workers, the colour classes carried in the caller — the same outputs."""
    src = FrameSource("campus", seed=5)
    frames = list(eval_frames(src, 12, np.random.default_rng(5), (0.5, 2.0)))
    # every fourth frame predicts nothing of colour: range alone (no colour step)
    jobs = [FrameJob(fr.sensor, tuple(o.model_copy(update={"colour": None}) for o in fr.objects) if k % 4 == 3 else fr.objects, fr.prior_pose)
            for k, fr in enumerate(frames)]
    pipe = PerceptionPipeline(ResolutionTable(src.table.sensor, max_distance=src.table.max_distance))
    alone = [_digest(pipe.process(colored_range_image(j.sensor), j.objects, j.prior_pose, error_allowance=1.0, step=1)) for j in jobs]
    methods = [d[0] for d in alone]
    assert {Segmentation.COLOUR, Segmentation.COLORED_RANGE, Segmentation.RANGE} <= set(methods), methods
    assert sum(d[6] is not None for d in alone) >= 6  # frames with a fix: the comparison covers the whole cycle
    # the colour classes carry from frame to frame: the same frames in another order give other labels
    pipe = PerceptionPipeline(ResolutionTable(src.table.sensor, max_distance=src.table.max_distance))
    shuffled = [_digest(o) for o in process_frames(pipe, jobs[::-1], error_allowance=1.0, step=1)][::-1]
    assert shuffled != alone
    for workers, batch in ((2, 12), (2, 5), (3, 12)):  # batch 5: three runs through the shared frame, the last short
        with VisionPool(workers, warm=("modules.perception",)) as pool:
            pipe = PerceptionPipeline(ResolutionTable(src.table.sensor, max_distance=src.table.max_distance), pool=pool)
            got = [_digest(o) for o in process_frames(pipe, jobs, error_allowance=1.0, step=1, batch=batch)]
        assert got == alone, f"{workers} workers, batches of {batch}: frames differ from one process at {[i for i, (a, b) in enumerate(zip(got, alone)) if a != b]}"
