"""Standard Zenoh tools that set no encoding still talk JSON to the system, and get JSON back.

The client here is a plain zenoh session (no project code): the router, the blackboard node and the
CAPTAIN run as real processes.
"""

from __future__ import annotations

import json
import sys
import threading

import pytest
import zenoh

from tests.modules._procs import spawn, stop
from wire.ports import free_port

NS = "plainjson"


@pytest.fixture(scope="module")
def system():
    ep = f"tcp/127.0.0.1:{free_port()}"
    net = ["--ns", NS, "--connect", ep]
    procs = [spawn([sys.executable, "-m", "sidewalk", "up", "router", "--ns", NS, "--listen", ep], "router ready")]
    try:
        procs.append(spawn([sys.executable, "-m", "sidewalk", "up", "blackboard", *net, "--types", "modules.vocabulary"], "blackboard ready"))
        procs.append(spawn([sys.executable, "-m", "sidewalk", "up", "captain", *net], "SIDEWALK-READY captain"))
        cfg = {"mode": "client", "scouting": {"multicast": {"enabled": False}}, "connect": {"endpoints": [ep]}}
        s = zenoh.open(zenoh.Config.from_json5(json.dumps(cfg)))
        try:
            yield s
        finally:
            s.close()
    finally:
        for p in reversed(procs):
            stop(p)


def _get(s: "zenoh.Session", key: str, payload: bytes) -> list[tuple[bool, str, bytes]]:
    out = []
    for r in s.get(key, payload=payload, timeout=15.0):  # no encoding: what z_get does without -E
        sample = r.ok if r.ok is not None else r.err
        out.append((r.ok is not None, str(sample.encoding), sample.payload.to_bytes()))
    return out


def test_json_mission_submit_and_retrieve_without_encoding(system) -> None:
    s = system
    events: list[dict] = []
    got = threading.Event()

    def on_event(sample: "zenoh.Sample") -> None:
        events.append(json.loads(sample.payload.to_bytes()))
        got.set()

    sub = s.declare_subscriber(f"sidewalk/{NS}/mission/events", on_event)
    mission = {"name": "plain-tool", "steps": [{"name": "hop", "destination": {"x": 3.0, "y": 4.0}}]}
    [(ok, enc, payload)] = _get(s, f"sidewalk/{NS}/mission/submit", json.dumps(mission).encode())
    assert ok and enc.startswith("application/json"), (enc, payload)
    accepted = json.loads(payload)
    assert accepted["name"] == "plain-tool" and accepted["steps"] == 1
    assert got.wait(15.0), "no mission status on the JSON stream"
    assert events[0]["mission_id"] == accepted["mission_id"]

    spec = {"type": "mission", "limit": 5}
    [(ok, enc, payload)] = _get(s, f"sidewalk/{NS}/bb/retrieve", json.dumps(spec).encode())
    assert ok and enc.startswith("application/json"), (enc, payload[:200])
    tokens = json.loads(payload)
    assert [t["attrs"]["name"] for t in tokens] == ["plain-tool"]

    # errors come back in the request's format too
    [(ok, enc, payload)] = _get(s, f"sidewalk/{NS}/bb/retrieve", b'{"type": "mission", "limit": -3}')
    assert not ok and enc.startswith("application/json")
    assert json.loads(payload)["error"] == "bad_spec"
    [(ok, enc, payload)] = _get(s, f"sidewalk/{NS}/mission/submit", b'{"name": "x", "steps": []}')
    assert not ok and json.loads(payload)["error"] == "invalid_mission"
    sub.undeclare()
