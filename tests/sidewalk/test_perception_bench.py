"""`sidewalk bench perception`: PERCEPTION's cycle time with the IoU beside it, as one strict JSON object."""

import json
import subprocess
import sys

import pytest


def _strict(text: str) -> dict:
    def no_constant(c: str) -> float:
        raise ValueError(f"not JSON: {c}")

    return json.loads(text, parse_constant=no_constant)


@pytest.mark.timeout(240)
def test_perception_bench_prints_the_cycle_and_the_iou():
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench", "perception", "--frames", "3", "--json"],
                       capture_output=True, text=True, timeout=220)
    assert p.returncode == 0, p.stderr[-2000:]
    r = _strict(p.stdout.splitlines()[0])
    assert r["frames"] == 3 and r["world"] == "campus"
    assert r["cycle_ms_p95"] >= r["cycle_ms_p50"] > 0 and r["cycle_cpu_ms_p50"] > 0
    assert sum(r["resolution_steps"].values()) == 3
    for m in ("colour", "range", "colored_range"):
        v = r[f"mean_iou_focus_{m}"]
        assert v is None or 0.0 <= v <= 1.0


def test_perception_bench_names_a_bad_world():
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench", "perception", "--world", "no-such-world", "--frames", "1"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode != 0
    assert "--world 'no-such-world'" in p.stderr and "Traceback" not in p.stderr
