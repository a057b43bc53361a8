"""A mission submitted at run time to an EDDIE system started with `sidewalk up` gets its trigger annotations.

The mission service compiles every mission it accepts and hands the annotations to the map manager
(started empty), so `sidewalk submit` of the AMV mission fires the triggers `sidewalk run --arch eddie`
fires: the speeds, dead reckoning at the four intersections, the stop at the mailbox.
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sidewalk.eddie_observe import TriggerView
from eddie.toolkit.message import decode_body
from tests.modules._procs import ROOT, spawn, stop
from vehicle_sim.worldfile import WORLDS_DIR, load_world
from wire.aio import Link
from wire.keys import EddieKeys
from wire.network import NetworkConfig
from wire.ports import free_port

RTF = "5"
MAP = WORLDS_DIR / "north_hills.map.geojson"


def _launched_triggers(out: Path) -> list[tuple[str, str]]:
    """Return (annotation, type) of every trigger `sidewalk run --arch eddie` fires on the AMV mission, in order."""
    cmd = [sys.executable, "-m", "sidewalk", "run", "--arch", "eddie", "--mission", "amv-delivery",
           "--rtf", RTF, "--seed", "0", "--out", str(out)]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads((out / "report.json").read_text())
    return [(t["annotation"], t["kind"]) for t in report["triggers"]]


async def _submitted_triggers(ns: str, ep: str) -> tuple[list[tuple[str, str]], list[TriggerView]]:
    """Return the triggers fired (annotation, type) and their views while `sidewalk submit` runs the AMV mission."""
    fired: list[TriggerView] = []

    def on_trigger(_key: str, payload: bytes) -> None:
        t = decode_body(TriggerView, payload, sender="map_manager")
        if t.event == "fired":
            fired.append(t)

    link = Link.open(NetworkConfig(namespace=ns, connect=(ep,)))
    try:
        link.subscribe(EddieKeys(ns).topic("map_manager", "triggers"), on_trigger)
        sub = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "sidewalk", "submit", "amv-delivery", "--ns", ns, "--connect", ep, "--timeout", "30",
            cwd=ROOT, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
        out, err = await asyncio.wait_for(sub.communicate(), 600)
        assert sub.returncode == 0, (out.decode()[-1500:], err.decode()[-1500:])
        assert "succeeded" in out.decode()
    finally:
        link.close()
    return [(t.annotation_id, t.trigger_type) for t in fired], fired


@pytest.mark.missions
@pytest.mark.timeout(1500)  # ~310 s on a busy machine (two AMV runs at RTF 5 with vision); no quiet figure yet
def test_a_mission_submitted_to_an_eddie_system_started_with_up_fires_the_launched_runs_triggers(tmp_path: Path) -> None:
    launched = _launched_triggers(tmp_path / "run")

    world = load_world(MAP, kind="map")
    assert world.start is not None
    start = f"--start-pose={world.start.x},{world.start.y},{math.radians(world.start.yaw_deg)}"
    ns = f"upsub{os.getpid()}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    conn = ["--ns", ns, "--connect", ep]
    up = [sys.executable, "-m", "sidewalk", "up"]
    procs: list[subprocess.Popen] = []
    try:
        procs.append(spawn([*up, "router", "--ns", ns, "--listen", ep], "router ready", timeout=120))
        procs.append(spawn([*up, "sim", "--world", "north_hills", "--vehicle", "navlab", "--rtf", RTF, "--seed", "0", *conn],
                           "ready sim", timeout=180))
        procs.append(spawn([*up, "controller", "--vehicle", "navlab", *conn], "SIDEWALK-READY controller", timeout=180))
        procs.append(spawn([*up, "navigator", start, *conn], "SIDEWALK-READY navigator", timeout=180))
        # no annotated map: the map manager holds only what the mission service hands it
        procs.append(spawn([*up, "map_manager", "--state", str(tmp_path / "mm.state.json"), *conn],
                           "SIDEWALK-READY map_manager", timeout=180))
        # the perception modules as `sidewalk run` starts them (obstacle stop asleep until the route's triggers wake it)
        for name in ("obstacle_stop", "landmark_matching", "road_following"):
            procs.append(spawn([*up, name, "--vehicle", "navlab", "--map", str(MAP), start, "--seed", "0", *conn,
                                *(("--asleep",) if name == "obstacle_stop" else ())], f"SIDEWALK-READY {name}", timeout=180))
        procs.append(spawn([*up, "mission_service", "--map", str(MAP), "--vehicle", "navlab", start, "--perception", "on", *conn],
                           "SIDEWALK-READY mission_service", timeout=180))
        submitted, views = asyncio.run(_submitted_triggers(ns, ep))
    finally:
        for p in reversed(procs):
            stop(p)

    kinds = [k for _a, k in submitted]
    assert kinds.count("dead_reckon_intersection") == 4, submitted  # Oak–Maple, Oak–Elm, Elm–Pine, Elm–Birch
    speeds = [a for a, k in submitted if k == "set_speed"]
    assert speeds[0] == "s1.speed" and len(speeds) >= 9, speeds  # cruise, then slow and cruise again at each intersection
    stop_at = [v for v in views if v.trigger_type == "stop_at_object"]
    assert len(stop_at) == 1 and "mailbox" in stop_at[0].text, stop_at
    assert submitted == launched
    # the state file keeps the mission's annotations beside it, for a restarted map manager
    kept = json.loads((tmp_path / "mm.state.json.mission.geojson").read_text())
    assert {f["id"] for f in kept["features"]} >= {a for a, _k in submitted}
