"""`sidewalk bench terrain-planner`: 50 m cross-country plans on 150k-cell generated maps, as one strict JSON object."""

import json
import subprocess
import sys

import pytest


def _strict(text: str) -> dict:
    def no_constant(c: str) -> float:
        raise ValueError(f"not JSON: {c}")

    return json.loads(text, parse_constant=no_constant)


@pytest.mark.timeout(600)  # quiet run ~3 s with numba's cache warm, ~35 s compiling from cold (busy machine), ~200 s at a load of 20
def test_terrain_planner_bench_prints_plans_queries_and_the_pyramid():
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench", "terrain-planner", "--seeds", "2", "--repeats", "1",
                        "--vehicle", "terregator", "--json"], capture_output=True, text=True, timeout=560)
    assert p.returncode == 0, p.stderr[-2000:]
    r = _strict(p.stdout.splitlines()[0])
    assert r["vehicle"] == "terregator" and r["seeds"] == [2] and r["cells"] == 387 * 387
    assert r["plans"] == 4 and r["failures"] == []  # hills, rocks, ditch, all three: each has a path
    assert r["plan_ms_p95"] >= r["plan_ms_p50"] > 0 and r["plan_cpu_ms_p50"] > 0
    assert 0 < r["queries_p50"] <= r["queries_max"] < r["fine_configurations"] / 100
    assert set(r["per_kind"]) == {"hills", "rocks", "ditch", "mixed"}
    assert all(45.0 < k["length_m_p50"] < 80.0 for k in r["per_kind"].values())  # 50 m apart, around what is in the way
    levels = r["voxels_by_level"]
    assert "-1" in levels and sum(sum(v.values()) for v in levels.values()) > 0
    assert r["pyramid_build_ms_p50"] > 0 and r["pyramid_update_ms_p50"] > 0


def test_terrain_planner_bench_names_a_bad_flag():
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench", "terrain-planner", "--seeds", "1,x"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode != 0 and "--seeds" in p.stderr and "Traceback" not in p.stderr
