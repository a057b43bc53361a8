"""PERCEPTION's cycles over a run of frames, whole frames among the vision workers (issue 41).

Most of a cycle is not per pixel — patches, object finding, the pose fit — so it does not split into
image stripes; frames do split (`modules.parallel.frames`). Each frame's head (registration,
view frame, predicted objects, colour training pixels, range segmentation) and tail (patches,
objects, navigable region, fix) run in one process, a worker's or the caller's; the colour step
(fit, classify, adapt the colour classes) carries the classes from frame to frame, so the caller
runs it for every frame in order. The capture's arrays and what passes between head, colour step
and tail (registered colour, mask, training labels, colour labels) lie in the pool's shared frame.

The outputs are those of `PerceptionPipeline.process` run frame after frame, which is what one
worker does. One difference is possible in principle: the view plan of each frame is drawn before
the frames run, so it cannot fold in the times of the frames before it as `process` does; the plan
depends on those times only when a cycle takes longer than the perception distance over the speed
(seconds, against the milliseconds a cycle takes).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

import numpy as np

from modules.parallel import Frame, FrameStages, run_frames
from modules.perception.patch_maker import Segmentation
from modules.perception.pipeline import CycleSetup, PerceptionPipeline, PipelineOutput, cycle_head, cycle_tail
from modules.perception.sensor_frame import SensorFrame, colored_range_image
from modules.vocabulary import MapObject

__all__ = ["FrameJob", "process_frames", "BATCH"]

#: Frames laid out in the shared frame at once (a longer run goes batch after batch).
BATCH = 48

_SENSOR = ("laser_range", "laser_valid", "laser_az", "laser_el", "camera_image")
_META = ("stamp", "ambiguity", "T_vehicle_laser", "T_vehicle_camera", "camera_K", "range_step")


@dataclass(frozen=True)
class FrameJob:
    """One frame to perceive: the capture `sensor`, the predicted map `objects` and the `prior_pose` (world←vehicle) [m, m, rad]."""

    sensor: SensorFrame
    objects: tuple[MapObject, ...]
    prior_pose: tuple[float, float, float]


def _head(arrays: Mapping[str, np.ndarray], args: tuple) -> tuple[tuple, None]:
    """Register one frame from the shared capture and run its cycle head; the colour step's inputs go to the shared frame."""
    meta, setup, objects, prior_pose, error_allowance = args
    t0 = time.perf_counter()
    frame = SensorFrame(**meta, **{n: arrays[n] for n in _SENSOR})
    head = cycle_head(colored_range_image(frame), setup, objects, prior_pose, error_allowance)
    if head.mask is not None:
        assert head.training is not None
        np.copyto(arrays["rgb"], head.work.rgb)
        np.copyto(arrays["mask"], head.mask)
        np.copyto(arrays["training"], head.training)
    return (head, setup, prior_pose, error_allowance, time.perf_counter() - t0), None


def _tail(arrays: Mapping[str, np.ndarray], kept: tuple, step_s: float) -> PipelineOutput:
    """Run one frame's cycle tail on the colour labels the colour step left in the shared frame.

    The output's label and patch-id images go back through the shared frame (`_with_images` puts them
    back), the rest pickled.
    """
    head, setup, prior_pose, error_allowance, head_s = kept
    t0 = time.perf_counter()
    colour_lab = arrays["colour_lab"] if head.mask is not None else None
    out = cycle_tail(head, colour_lab, setup, prior_pose, error_allowance)
    seg = out.segmented
    np.copyto(arrays["labels"], seg.labels, casting="no")
    np.copyto(arrays["ids"], seg.patches.ids, casting="no")
    seg = replace(seg, labels=None, patches=replace(seg.patches, ids=None))
    return replace(out, segmented=seg, seconds=head_s + step_s + time.perf_counter() - t0)


def _with_images(out: PipelineOutput, arrays: Mapping[str, np.ndarray]) -> PipelineOutput:
    """Return a tail's output with its label and patch-id images copied out of the shared frame."""
    seg = out.segmented
    seg = replace(seg, labels=arrays["labels"].copy(), patches=replace(seg.patches, ids=arrays["ids"].copy()))
    return replace(out, segmented=seg)


_STAGES = FrameStages(_head, _tail)


def _frame(job: FrameJob, method: Segmentation, step: int) -> Frame:
    """Return one frame of the run: the capture's arrays in; out, its images and what passes through the colour step."""
    h, w = job.sensor.laser_range.shape
    hw = (-(-h // step), -(-w // step)) if step > 1 else (h, w)
    outputs: dict[str, tuple[tuple[int, ...], Any]] = {"labels": (hw, np.int32), "ids": (hw, np.int32)}
    if method is not Segmentation.RANGE:
        outputs.update({"rgb": ((*hw, 3), np.float32), "mask": (hw, np.bool_), "training": (hw, np.int16), "colour_lab": (hw, np.int16)})
    return Frame({n: np.asarray(getattr(job.sensor, n)) for n in _SENSOR}, outputs)


def process_frames(pipeline: PerceptionPipeline, jobs: Sequence[FrameJob], *, error_allowance: float = 0.5,
                   step: int | None = None, batch: int = BATCH) -> list[PipelineOutput]:
    """Run a PERCEPTION cycle on each frame, in order; return the outputs (those of `pipeline.process`, frame after frame).

    With a `pipeline.pool` of several workers the frames run overlapped over its processes, `batch`
    frames at a time (see the module docstring); `seconds` of each output is its own stages' time,
    not the wall time of the run.
    """
    pool = pipeline.pool
    if pool is None or pool.workers == 1:
        return [pipeline.process(colored_range_image(j.sensor), j.objects, j.prior_pose, error_allowance=error_allowance, step=step)
                for j in jobs]
    outs: list[PipelineOutput] = []
    for at in range(0, len(jobs), batch):
        outs += _batch(pipeline, list(jobs[at:at + batch]), error_allowance, step)
    return outs


def _batch(pipeline: PerceptionPipeline, jobs: list[FrameJob], error_allowance: float, step: int | None) -> list[PipelineOutput]:
    pool = pipeline.pool
    assert pool is not None
    layout = [pipeline.method_and_plan(j.objects, error_allowance, step=step) for j in jobs]
    setups: dict[int, CycleSetup] = {}

    def head_args(k: int) -> tuple:  # as frame k is handed out, in frame order, as `process` would
        job = jobs[k]
        setups[k] = pipeline.setup(job.objects, error_allowance, step=step)
        return {n: getattr(job.sensor, n) for n in _META}, setups[k], job.objects, job.prior_pose, error_allowance

    def colour_step(k: int, _: None, arrays: Mapping[str, np.ndarray]) -> float:
        setup = setups[k]
        if not setup.types:
            return 0.0
        t0 = time.perf_counter()
        # the step runs while workers hold tasks: no striped classification here (the same labels either way)
        lab = pipeline.colour_step(setup, jobs[k].objects, arrays["rgb"], arrays["mask"], arrays["training"], striped=False)
        assert lab is not None
        np.copyto(arrays["colour_lab"], lab)
        return time.perf_counter() - t0

    outs = run_frames(pool, _STAGES, [_frame(j, m, p.step) for j, (m, p) in zip(jobs, layout)], head_args, colour_step,
                      gather=lambda k, out, arrays: _with_images(out, arrays))
    for k, out in enumerate(outs):
        pipeline.table.record(setups[k].plan.step, out.seconds)
    return outs
