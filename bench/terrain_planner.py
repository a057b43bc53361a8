"""Cross-country planner benchmark (Navlab 1990 §2.4): a 50 m plan on a 150k-cell map, and the terrain pyramid under it.

`run(vehicle, seeds, repeats)` generates the fixed scenes of `bench.terrain_scenes` (hills, rocks, a
ditch, all three; 387 × 387 cells of 0.2 m = 149,769 cells) for each seed, builds each scene's
pyramid, plans from its start to its goal 50 m away `repeats` times (each plan starts with an empty
voxel cache, as after a new map) and returns one dict (printed as JSON by
`sidewalk bench terrain-planner --json`):
- `plan_ms_p50`, `plan_ms_p95`: wall time of one plan [ms] (pyramid built; the cost to go, the search
  and the voxel classification included), over every plan of every scene that has a path;
  `plan_cpu_ms_p50`: the process CPU time of the same plans [ms] (robust to other processes on the
  cores; `load_avg_1min` says how busy the machine was);
- `queries_p50`, `queries_max`: terrain queries per plan (voxels and single configurations classified
  from the pyramid; the paper's Figure 2.16 plan made 1,493), `node_reads_p50` the pyramid nodes
  they read, `fine_configurations` what a pixel-sized tessellation (cells × finest heading intervals)
  would evaluate, `queries_share_of_fine_p50` the ratio;
- `voxels_by_level`: voxels classified admissible / inadmissible / mixed per level of the hierarchy,
  summed over one plan of each scene (level −1: configurations bounded one by one);
- `pyramid_build_ms_p50`: building the whole pyramid of one map [ms]; `pyramid_update_ms_p50`:
  updating it after a 12.8 m × 12.8 m block (4,096 cells, about what one ERIM image adds) changed;
- `per_kind`: plan_ms_p50, queries_p50 and path length per scene kind; `failures`: scenes with no
  plan and the planner's one-line reason (none expected).
The first plan and build (numba compilation or cache load) run before anything is timed.
"""

from __future__ import annotations

import os
import time

import numpy as np

from wire.summary import percentile

__all__ = ["run"]


def _p(values: list[float], q: float) -> float | None:
    return percentile(values, q, digits=3)


def run(vehicle: str = "navlab", seeds: tuple[int, ...] = (1, 2, 3), repeats: int = 5) -> dict:
    """Benchmark the planner of `vehicle` on every scene kind for each of `seeds`, `repeats` plans each; return the figures."""
    from bench.terrain_scenes import SCENE_KINDS, scene
    from modules.terrain.cross_country_planner import CrossCountryPlanner
    from modules.terrain.errors import TerrainPlanningError
    from modules.terrain.pyramid import TerrainPyramid
    from modules.terrain.vehicle_model import terrain_vehicle_for

    model = terrain_vehicle_for(vehicle)
    warm = scene("hills", 0, cells=128)  # 25.6 m across: a short plan on smooth ground compiles every part
    warm_pyramid = TerrainPyramid(warm.grid)
    warm_pyramid.update(warm.grid, 10, 20, 10, 20)
    CrossCountryPlanner(warm_pyramid, model).plan((6.0, 12.8, 0.0), (19.0, 12.8, 0.0))
    wall: list[float] = []
    cpu: list[float] = []
    queries: list[float] = []
    reads: list[float] = []
    builds: list[float] = []
    updates: list[float] = []
    per_kind: dict[str, dict[str, list[float]]] = {k: {"ms": [], "queries": [], "length": []} for k in SCENE_KINDS}
    by_level: dict[int, list[int]] = {}
    failures: list[str] = []
    fine = 0
    cells = 0
    for seed in seeds:
        for kind in SCENE_KINDS:
            sc = scene(kind, seed)
            cells = sc.grid.z.size
            t0 = time.perf_counter()
            pyramid = TerrainPyramid(sc.grid)
            builds.append((time.perf_counter() - t0) * 1e3)
            ny, nx = sc.grid.shape
            i0, j0 = ny // 2 - 32, nx // 2 - 32
            t0 = time.perf_counter()
            pyramid.update(sc.grid, i0, i0 + 64, j0, j0 + 64)
            updates.append((time.perf_counter() - t0) * 1e3)
            planner = CrossCountryPlanner(pyramid, model)
            for rep in range(repeats):
                c0, t0 = time.process_time(), time.perf_counter()
                try:
                    plan = planner.plan(sc.start, sc.goal)
                except TerrainPlanningError as exc:
                    failures.append(f"{kind} seed {seed}: {exc}")
                    break
                wall.append((time.perf_counter() - t0) * 1e3)
                cpu.append((time.process_time() - c0) * 1e3)
                queries.append(plan.terrain_queries)
                reads.append(plan.node_reads)
                fine = plan.fine_configurations
                per_kind[kind]["ms"].append(wall[-1])
                per_kind[kind]["queries"].append(plan.terrain_queries)
                per_kind[kind]["length"].append(plan.length)
                if rep == 0:
                    for lc in plan.voxels:
                        row = by_level.setdefault(lc.level, [0, 0, 0])
                        row[0] += lc.admissible
                        row[1] += lc.inadmissible
                        row[2] += lc.mixed
    return {
        "vehicle": vehicle,
        "seeds": list(seeds),
        "repeats": repeats,
        "cells": cells,
        "plans": len(wall),
        "plan_ms_p50": _p(wall, 50),
        "plan_ms_p95": _p(wall, 95),
        "plan_cpu_ms_p50": _p(cpu, 50),
        "queries_p50": _p(queries, 50),
        "queries_max": int(max(queries)) if queries else 0,
        "node_reads_p50": _p(reads, 50),
        "fine_configurations": fine,
        "queries_share_of_fine_p50": round(float(np.median(queries)) / fine, 6) if fine else None,
        "voxels_by_level": {str(k): {"admissible": v[0], "inadmissible": v[1], "mixed": v[2]}
                            for k, v in sorted(by_level.items(), reverse=True)},
        "pyramid_build_ms_p50": _p(builds, 50),
        "pyramid_update_ms_p50": _p(updates, 50),
        "per_kind": {k: {"plan_ms_p50": _p(v["ms"], 50), "queries_p50": _p(v["queries"], 50),
                         "length_m_p50": _p(v["length"], 50)} for k, v in per_kind.items()},
        "failures": failures,
        "load_avg_1min": round(os.getloadavg()[0], 2),
    }
