"""`sidewalk terrain eval`, `sidewalk bench terrain` and `sidewalk worldgen` as a user runs them: real processes, clear errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

SIDEWALK = [str(Path(sys.executable).parent / "sidewalk")]


def _run(*args: str, timeout: float = 200.0) -> subprocess.CompletedProcess:
    return subprocess.run([*SIDEWALK, *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.timeout(240)  # quiet run ~15 s
def test_terrain_eval_scores_both_maps_on_the_shipped_world() -> None:
    r = _run("terrain", "eval", "--world", "cross_country", "--images", "6", "--json")
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    locus, bucket = rep["locus"], rep["bucket"]
    assert rep["world"] == "cross_country" and rep["images"] == 6
    assert locus["rms_within_m"] <= 0.10 and locus["rms_within_m"] < bucket["rms_within_m"]
    assert locus["known_share"] > 2.0 * bucket["known_share"]  # the locus map is dense, buckets leave holes
    assert 0.0 <= locus["unknown_shadowed_share"] <= locus["unknown_near_shadow_share"] <= 1.0
    assert locus["update_ms_p50"] > 0 and locus["update_cpu_ms_p50"] > 0
    assert rep["pyramid_build_ms"] is None


@pytest.mark.timeout(120)  # quiet run ~5 s
@pytest.mark.parametrize("args, says", [
    (("terrain", "eval", "--world", "campus"), "has no terrain"),
    (("terrain", "eval", "--world", "no_such_world"), "--world"),
    (("terrain", "eval", "--pose-noise", "1"), "M,DEG"),
    (("bench", "terrain", "--world", "campus"), "has no terrain"),
    (("worldgen", "suburbia"), "cross-country"),
    (("worldgen", "cross-country", "--name", "../up"), "--name"),
])
def test_bad_flags_say_where_and_what(args: tuple[str, ...], says: str) -> None:
    r = _run(*args)
    assert r.returncode != 0 and says in r.stderr and "Traceback" not in r.stderr, r.stderr
