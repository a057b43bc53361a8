"""Fuzz every endpoint of a live system (`sidewalk bench fuzz`): real processes on loopback Zenoh — the
blackboard node, the simulator, the CAPTAIN, EDDIE's controller, navigator and map manager — get
generated payloads (seeded numpy Generator: random bytes, truncated msgpack/JSON, wrong types, 2 MB
and 10 MB payloads) on every queryable and subscribed key; every query is answered validly or with a
typed error (never a huge echo) or ignored, and every process still serves a valid request after."""

import json
import subprocess
import sys

import numpy as np
import pytest

from bench.fuzz import PAYLOAD_KINDS, generate_payloads


def test_the_payload_generator_is_seeded_and_covers_every_kind():
    a = generate_payloads(np.random.default_rng(3), 40)
    b = generate_payloads(np.random.default_rng(3), 40)
    assert a == b and len(a) == 40
    assert {k for k, _ in a} == set(PAYLOAD_KINDS)
    assert a[0][0] == "huge" and len(a[0][1]) == 2 * 1024 * 1024
    assert a != generate_payloads(np.random.default_rng(4), 40)


@pytest.mark.e2e
@pytest.mark.timeout(900)  # nine processes start, then 300 payloads per key; the bench's own limit well inside this one
def test_every_endpoint_answers_garbage_with_typed_errors_and_keeps_serving():
    p = subprocess.run([sys.executable, "-m", "sidewalk", "bench", "fuzz", "--payloads", "300", "--seed", "1", "--json"],
                       capture_output=True, text=True, timeout=780)
    r = json.loads(p.stdout.splitlines()[0])
    assert r["violation_count"] == 0, r["violations"]
    assert r["still_serving"] == {n: True for n in ("blackboard", "sim", "captain", "controller", "navigator", "map_manager")}, \
        r["not_serving_why"]
    assert all(r["alive"].values()), r["alive"]
    assert p.returncode == 0, p.stderr[-2000:]
    # every key got its payloads, and the garbage was refused with typed errors, not merely ignored
    assert r["queryables"] >= 20 and r["subscribed"] >= 8
    assert r["payloads"] == 300 * (r["queryables"] + r["subscribed"])  # the CAPTAIN's 10 MB submit is one of its 300
    assert r["typed_errors"] > 0.5 * 300 * r["queryables"], r
    assert all(c == 0 for c in r["exit_codes"].values()), r["exit_codes"]
    assert "Traceback" not in p.stderr
