"""End to end: a mission cancelled under EDDIE with vision stops the vehicle, and the stop holds.

The mission service stops the controller on a cancel; vision road following, whose paths outrank the
mission service's, must go to sleep too, or its next path drives on along the route. Real processes,
real Zenoh on loopback; truth (the recorder's) judges where the vehicle stood.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from sidewalk.mission_client import MissionClient
from sidewalk.eddie_run import EddieSystemRun, compile_annotated_map, eddie_plans
from sidewalk.launcher import RunConfig, prepare_run
from tests.sidewalk._mission import drive_to
from wire.keys import ModuleKeys
from wire.ports import free_port

DATA = Path(__file__).parent / "data"


@pytest.mark.missions
@pytest.mark.e2e
@pytest.mark.timeout(300)
async def test_a_mission_cancelled_under_vision_stops_the_vehicle_for_good(tmp_path):
    cfg = RunConfig(world="campus", mission=str(DATA / "short-hop.yaml"), rtf=10.0, seed=3, out=tmp_path, arch="eddie")
    setup = prepare_run(cfg)
    ns, endpoint = f"cancel{os.getpid()}", f"tcp/127.0.0.1:{free_port()}"
    amap = compile_annotated_map(setup, tmp_path)
    plans = eddie_plans(cfg, setup, ns, endpoint, annotated_map=amap)
    assert "road_following" in {p.name for p in plans}
    system = EddieSystemRun(plans, ns=ns, endpoint=endpoint, log_dir=tmp_path / "logs", annotated_map=amap)
    try:
        await system.start(ready_timeout=90)
        mid = await system.submit(setup.mission_file.read_text())
        await system.wait_status(mid, lambda s: s.state == "running", timeout=60)
        await drive_to(system, mid, 8.0)  # vision is driving: the vehicle is under way along the route
        status = await MissionClient(system.link, ModuleKeys(ns)).cancel(mid, "the test cancels it")
        assert status.state == "cancelled"
        driven_at_cancel = system.recorder.distance_m()
        # still for 15 s sim within 40 s sim of the cancel: a vehicle that drove on along the route (50 m
        # and more left, at up to 1 m/s) would not be
        rest = await system.recorder.wait_rest(still_s=15.0, max_sim_s=40.0, max_wall_s=120.0)
        assert rest is not None, f"the vehicle did not stay stopped: {system.recorder.distance_m() - driven_at_cancel:.1f} m after the cancel"
        assert system.recorder.distance_m() - driven_at_cancel < 3.0  # it stopped where it was, not somewhere on along the route
    finally:
        codes = await system.close()
    assert all(c == 0 for c in codes.values()), codes
    service_log = (tmp_path / "logs" / "mission_service.log").read_text()
    road_log = (tmp_path / "logs" / "road_following.log").read_text()
    assert "Traceback" not in service_log + road_log
