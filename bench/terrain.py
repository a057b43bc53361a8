"""Terrain benchmark: the robot's elevation-map update per ERIM image (256 × 64 = 16,384 pixels), with the accuracy beside it.

`run(world, images, seed)` runs the same evaluation as `sidewalk terrain eval` (ERIM images along a
feasible track of a world with terrain) and returns one dict (printed as JSON by `sidewalk bench
terrain --json`):
- `update_ms_p50`, `update_cpu_ms_p50`: one update of the locus map (unwrap and median-filter the
  image, the locus map at 0.1 m out to 20 m, z registration by the mean difference, fusion) [ms],
  wall and process CPU (robust to other processes competing for the cores; `load_avg_1min` says how
  busy the machine was); `bucket_update_ms_p50`, `bucket_update_cpu_ms_p50` the same with the bucket map;
- `pixels_per_image`: the scanner's pixels (every one is read; the valid ones become points);
- `locus_rms_within_m`, `bucket_rms_within_m`: the maps' RMS elevation error within 20 m (the figures
  a speed-up must leave unchanged);
- `pyramid_build_ms`: null until the terrain pyramid (issue 40 part B) is merged.
"""

from __future__ import annotations

__all__ = ["run"]


def run(world: str = "cross_country", images: int = 30, seed: int = 0) -> dict:
    """Benchmark the terrain update on `images` ERIM images of `world` from `seed`; return the figures."""
    from sidewalk.terrain_eval import TerrainEvalConfig, evaluate
    from vehicle_sim.sensors.laser import LaserConfig
    from vehicle_sim.worldfile import load_world

    rep = evaluate(load_world(world), TerrainEvalConfig(images=images, spacing_m=1.0, seed=seed))
    laser = LaserConfig()
    return {
        "world": rep["world"], "images": rep["images"], "seed": seed, "pixels_per_image": laser.rows * laser.cols,
        "update_ms_p50": rep["locus"]["update_ms_p50"], "update_cpu_ms_p50": rep["locus"]["update_cpu_ms_p50"],
        "bucket_update_ms_p50": rep["bucket"]["update_ms_p50"], "bucket_update_cpu_ms_p50": rep["bucket"]["update_cpu_ms_p50"],
        "locus_rms_within_m": rep["locus"]["rms_within_m"], "bucket_rms_within_m": rep["bucket"]["rms_within_m"],
        "pyramid_build_ms": rep["pyramid_build_ms"], "load_avg_1min": rep["load_avg_1min"],
    }
