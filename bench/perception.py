"""PERCEPTION benchmark: the cycle time from a captured frame to the driving unit's result, with the IoU beside it.

`run(world, frames, seed)` runs the same evaluation as `sidewalk perception eval` (frames captured by
the simulator along the world's routes, priors off by the default pose error) and returns one dict
(printed as JSON by `sidewalk bench perception --json`):
- `cycle_ms_p50`, `cycle_ms_p95`: one cycle (colored-range image, monitor, PATCH MAKER, OBJECT FINDER,
  POSITION CALIBRATOR, result) at default resolution [ms] wall;
- `cycle_cpu_ms_p50`: the process CPU time of the same cycles [ms] (robust to other processes
  competing for the cores; `load_avg_1min` says how busy the machine was);
- `mean_iou_focus_<method>`: the mean IoU of slope, stairs and grass on the frames that show all
  three, per segmentation (the figures a speed-up must leave unchanged; null without such a frame);
- `capture_ms_p50`: the simulator's capture of the frame [ms] (for scale; not part of the cycle);
- `resolution_steps`: how many cycles ran at each subsampling step (the monitor picks the step from
  the measured cycle times, so a loaded machine may pick another; the IoU figures segment every frame
  at full resolution and do not depend on it).
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["run"]


def run(world: str = "campus", frames: int = 60, seed: int = 0) -> dict:
    """Benchmark PERCEPTION's cycle on `frames` frames of `world` from `seed`; return the figures."""
    from modules.perception.pipeline import PerceptionPipeline
    from sidewalk.cli._perception import FrameSource, eval_frames
    from sidewalk.perception_eval import evaluate

    pose_error = (0.5, 2.0)
    src = FrameSource(world, seed=seed)
    rng = np.random.default_rng(seed)
    pipe = PerceptionPipeline(src.table)
    with np.errstate(all="ignore"):
        allowance = max(0.5, 2.0 * pose_error[0])  # as `sidewalk perception eval`
        rep = evaluate(eval_frames(src, frames, rng, pose_error), pipe, error_allowance=allowance).as_dict()
    out = {
        "world": world,
        "frames": rep["frames"],
        "seed": seed,
        "cycle_ms_p50": round(rep["cycle_ms_p50"], 2),
        "cycle_ms_p95": round(rep["cycle_ms_p95"], 2),
        "cycle_cpu_ms_p50": round(rep["cycle_cpu_ms_p50"], 2),
        "capture_ms_p50": round(rep["capture_ms_p50"], 2),
        "load_avg_1min": round(os.getloadavg()[0], 2),
        "position_fixes": rep["position_fix"]["point"]["count"] + rep["position_fix"]["line"]["count"],
        "resolution_steps": rep["resolution_steps"],
    }
    for method, v in rep["mean_iou_focus"].items():
        iou = v["mean_iou"]
        out[f"mean_iou_focus_{method}"] = None if iou != iou else iou  # NaN (no focus frame) is not JSON
    return out
