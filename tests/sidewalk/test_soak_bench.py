"""A short soak (`sidewalk bench soak`) against a real node: every post acknowledged, every notification
delivered once, the figures printed as one JSON object (the 10-minute soak is the benchmark itself)."""

import json
import subprocess
import sys

import pytest


@pytest.mark.timeout(240)
def test_a_short_soak_loses_no_notification():
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench", "soak", "--minutes", "0.2", "--rate", "200",
                        "--monitors", "5", "--keep", "500", "--json"], capture_output=True, text=True, timeout=220)
    assert p.returncode == 0, p.stderr[-2000:]
    r = json.loads(p.stdout.splitlines()[0])
    assert r["posts"] >= 0.9 * 200 * 12, r  # the schedule was kept
    assert r["post_errors"] == 0 and r["lost"] == 0 and r["duplicates"] == 0, r
    assert r["notifications"] == r["posts"]
    assert [m["minute"] for m in r["per_minute"]] == [1] and r["per_minute"][0]["posts"] == r["posts"]
    assert r["latency_p99_ms"] >= r["latency_p50_ms"] > 0
    assert 0 < r["node_rss_mb_start"] <= r["node_rss_mb_max"] and r["node_rss_mb_end"] > 0
