"""Parallel vision benchmark (issue 41): time per frame and speed-up over 1, 2, 4 … vision workers, per algorithm.

`run(world, frames, rounds, seed, max_workers)` returns one dict (printed as JSON by
`sidewalk bench parallel --json`). Worker counts are 1, 2, 4, … up to `max_workers` (default: the
machine's cores); a pool of each count is open throughout. After one warm-up round, each of
`rounds` rounds runs every algorithm over the same frames at every count in turn (so a change in
the machine's load falls on all counts alike); the figure is the median over the rounds of
a pass's wall time per frame [ms]:

Every pool runs each of its processes with one library thread per operation (`intra_threads=1`:
OpenCV's and BLAS's own threads off), so a count's speed-up is the partitioning's, as the Warp's
cells' was; `perception_cycle` also gives one process with its libraries' own threads
(`library_threads_ms_per_frame`, as the live module runs with one worker) and the speed-up of each
count over that (`speedup_over_library_threads`).

- `perception_cycle`: registration (`colored_range_image`) and one PERCEPTION cycle (full
  resolution) per frame on campus frames, half on the slope and stairs, as one run of frames
  (`modules.perception.process_frames`: whole frames among the workers, the colour step in the
  caller in frame order), so the figure is throughput — wall time of the run over its frames —
  not one frame's latency, which no worker count shortens; `identical` says whether every output
  (labels, patches, objects found, fix) equals one process's;
- `colour_step`: the cycle's one stage that carries state from frame to frame (colour classes
  fitted, classified, adapted), alone: the serial part of the cycle;
- `registration`, `colour_classification`: the per-pixel stages `PerceptionPipeline.process` splits
  into stripes for a single frame (the live module's path), alone;
- `scarf_frame`: SCARF with the texture operator and ISODATA on north_hills frames (`identical`
  likewise), and `scarf_look`, its split stages alone (reduction, texture, classification).

`perception_split_share` is the share of one-process cycle time that runs in the workers (all but
the colour step), and `amdahl_bound` the speed-up the cycle could reach with it: 1 / (serial + split / N);
`pipeline_bound` is the bound of frame partitioning itself, whose serial colour step overlaps
the workers' frames: min(N, cycle / colour step). `stripe_split_share` and `stripe_amdahl_bound`
are the share and bound for a single frame split into stripes (registration and colour
classification alone, the live module's path). Beside them,
the Warp's measured speed-ups (Navlab 1990 §4.3.2, §4.4.3). `load_avg_1min` says how busy the
machine was: on a shared machine the figures are provisional.
"""

from __future__ import annotations

import contextlib
import os
import statistics
import time
from typing import Callable

import numpy as np

__all__ = ["run", "WARP"]

#: The Warp's speed-ups as the paper measured them, against a Vax 780 (FIDO) or a Sun 3 (SCARF).
WARP = {
    "interest_operator": {"cells": 10, "speedup": 26.5, "scheme": "input partitioning, stripes overlapping by 4 px"},
    "pyramid_correlation": {"cells": 9, "speedup": 78.0, "scheme": "systolic (input partitioning in W2)"},
    "image_pyramid": {"cells": 9, "speedup": 14.0, "scheme": "systolic; communication-bound"},
    "fido_step": {"cells": 10, "speedup": round(8.5 / 4.8, 2), "scheme": "whole step, Warp 4.8 s against a Sun 3's 8.5 s"},
    "scarf_production": {"cells": 10, "speedup": 6.0, "scheme": "rows among cells; against a Sun 3"},
    "scarf_final": {"cells": 10, "speedup": 10.0, "scheme": "1 s of Warp time (30×), 3 s in all against a Sun 3"},
}


def _counts(max_workers: int) -> list[int]:
    out, n = [1], 2
    while n <= max_workers:
        out.append(n)
        n *= 2
    if out[-1] != max_workers and max_workers > 1:
        out.append(max_workers)
    return out


def _digest(out) -> tuple:
    cal = out.calibration
    return (out.method, out.segmented.labels.tobytes(), out.segmented.patches.ids.tobytes(),
            tuple((p.polygon, p.edge_flags) for p in out.segmented.patches.patches),
            tuple((f.predicted.obj.object_id, tuple(p.id for p in f.patches)) for f in out.found),
            None if cal is None else (cal.pose, cal.covariance.tobytes()), out.failure)


def run(world: str = "campus", frames: int = 12, rounds: int = 3, seed: int = 0, max_workers: int | None = None) -> dict:
    """Benchmark the split algorithms over 1, 2, 4 … workers; return the figures (see the module docstring)."""
    from modules.parallel import VisionPool
    from modules.perception.monitor import ResolutionTable
    from modules.perception.patch_maker.colour_stripes import classify
    from modules.perception.frame_cycles import FrameJob, process_frames
    from modules.perception.pipeline import PerceptionPipeline, cycle_head
    from modules.perception.sensor_frame import colored_range_image
    from modules.road_following import CameraGeometry, Scarf, ScarfConfig
    from modules.road_following.scarf_stripes import LookParams, look
    from sidewalk.cli._perception import FrameSource, eval_frames
    from sidewalk.cli._roadfollow import RouteFrames
    from sidewalk.roadfollow_eval import plan_drive

    cores = os.cpu_count() or 1
    counts = _counts(max_workers or cores)
    src = FrameSource(world, seed=seed)
    pframes = list(eval_frames(src, frames, np.random.default_rng(seed), (0.5, 2.0)))
    road = RouteFrames("north_hills", seed=seed)
    rng = np.random.default_rng(seed)
    caps = [road.capture(p, rng) for p in plan_drive(road.legs, frames, rng, step_m=3.0)]
    cam = CameraGeometry.from_capture(caps[0])
    scarf_cfg = ScarfConfig(texture=True, colour_model="isodata")
    # the classes a SCARF run has after its first frames, for the split stages alone
    warm = Scarf(cam, scarf_cfg)
    for c in caps[:3]:
        warm.observe(c.camera_image)
    look_params = LookParams(scarf_cfg.rows, scarf_cfg.cols, True, scarf_cfg.texture_alpha, scarf_cfg.texture_threshold, warm.classes)
    out: dict = {"world": world, "frames": frames, "rounds": rounds, "seed": seed, "cores": cores, "workers": counts,
                 "algorithms": {}, "warp": WARP}
    jobs = [FrameJob(fr.sensor, fr.objects, fr.prior_pose) for fr in pframes]

    def cycle_on(pool: VisionPool) -> list:
        pipe = PerceptionPipeline(ResolutionTable(src.table.sensor, max_distance=src.table.max_distance), pool=pool)
        return [_digest(o) for o in process_frames(pipe, jobs, error_allowance=1.0, step=1)]

    # one process with its libraries' own threads (OpenCV's, BLAS's: as many as cores), before any pool limits them
    with VisionPool(1, intra_threads=None) as own:
        lib_ms = []
        for r in range(rounds + 1):
            t0 = time.perf_counter()
            lib_out = cycle_on(own)
            if r > 0:
                lib_ms.append((time.perf_counter() - t0) * 1e3 / frames)
    with contextlib.ExitStack() as stack:
        # every count with one library thread per process: the speed-up is the partitioning's, as the Warp's cells
        pools = {n: stack.enter_context(VisionPool(n, warm=("modules.perception", "modules.road_following"), intra_threads=1))
                 for n in counts}
        for pool in pools.values():
            pool.wait_ready()
        model = PerceptionPipeline(src.table).colour_model_for(pframes[0].objects)
        imgs = [colored_range_image(fr.sensor) for fr in pframes]

        ref = PerceptionPipeline(ResolutionTable(src.table.sensor, max_distance=src.table.max_distance))
        setups = [ref.setup(fr.objects, 1.0, step=1) for fr in pframes]
        heads = [cycle_head(im, su, fr.objects, fr.prior_pose, 1.0) for im, su, fr in zip(imgs, setups, pframes)]

        def algorithms(pool: VisionPool) -> dict[str, Callable[[], list]]:
            """Return each algorithm as one pass over the frames on `pool`, returning its outputs."""
            def fresh() -> PerceptionPipeline:  # a fresh pipeline each pass: its colour classes adapt frame to frame
                return PerceptionPipeline(ResolutionTable(src.table.sensor, max_distance=src.table.max_distance), pool=pool)

            def cycle() -> list:
                return cycle_on(pool)

            def colour_step() -> list:
                pipe = fresh()
                return [pipe.colour_step(su, fr.objects, h.work.rgb, h.mask, h.training) for su, fr, h in zip(setups, pframes, heads)]

            def scarf() -> list:
                s = Scarf(cam, scarf_cfg, pool=pool)
                return [s.observe(c.camera_image, stamp=float(i)).model_dump(exclude={"ms_per_frame"}) for i, c in enumerate(caps)]

            return {
                "perception_cycle": cycle,
                "colour_step": lambda: [None if lab is None else int(lab.sum()) for lab in colour_step()],
                "registration": lambda: [int(colored_range_image(fr.sensor, pool=pool).valid.sum()) for fr in pframes],
                "colour_classification": lambda: [int(classify(model, im.rgb, im.valid, pool)[0].sum()) for im in imgs],
                "scarf_frame": scarf,
                "scarf_look": lambda: [float(look(c.camera_image, look_params, pool).classified.p_road.sum()) for c in caps],
            }

        runs = {n: algorithms(pool) for n, pool in pools.items()}
        times: dict[tuple[str, int], list[float]] = {}
        outputs: dict[tuple[str, int], list] = {}
        for r in range(rounds + 1):
            for name in runs[1]:
                for n in counts:
                    t0 = time.perf_counter()
                    outputs[(name, n)] = runs[n][name]()
                    if r > 0:  # round 0 warms caches and the workers' imports
                        times.setdefault((name, n), []).append((time.perf_counter() - t0) * 1e3 / frames)
    for (name, n), ts in times.items():
        a = out["algorithms"].setdefault(name, {"ms_per_frame": {}, "speedup": {}})
        a["ms_per_frame"][str(n)] = round(statistics.median(ts), 2)
    for name, a in out["algorithms"].items():
        for n in counts[1:]:
            a["speedup"][str(n)] = round(a["ms_per_frame"]["1"] / a["ms_per_frame"][str(n)], 3)
        if name in ("perception_cycle", "scarf_frame"):
            a["identical"] = all(outputs[(name, n)] == outputs[(name, 1)] for n in counts)
    pc = out["algorithms"]["perception_cycle"]
    pc["library_threads_ms_per_frame"] = round(statistics.median(lib_ms), 2)
    pc["library_threads_identical"] = lib_out == outputs[("perception_cycle", 1)]
    pc["speedup_over_library_threads"] = {str(n): round(pc["library_threads_ms_per_frame"] / pc["ms_per_frame"][str(n)], 3)
                                          for n in counts[1:]}
    alg = out["algorithms"]
    cycle_ms = max(alg["perception_cycle"]["ms_per_frame"]["1"], 1e-9)
    for key, split in (("", cycle_ms - alg["colour_step"]["ms_per_frame"]["1"]),
                       ("stripe_", alg["registration"]["ms_per_frame"]["1"] + alg["colour_classification"]["ms_per_frame"]["1"])):
        share = min(1.0, max(0.0, split / cycle_ms))
        out[f"{key or 'perception_'}split_share"] = round(share, 3)
        out[f"{key}amdahl_bound"] = {str(n): round(1.0 / ((1.0 - share) + share / n), 3) for n in counts if n > 1}
    serial = max(alg["colour_step"]["ms_per_frame"]["1"], 1e-9)
    out["pipeline_bound"] = {str(n): round(min(float(n), cycle_ms / serial), 3) for n in counts if n > 1}
    out["load_avg_1min"] = round(os.getloadavg()[0], 2)
    return out
