"""Faults across processes: a killed module does not take the others down, and the system takes
the next mission after a bad one. Real processes, real Zenoh on loopback."""

import asyncio
from pathlib import Path

import pytest

from wire.ports import free_port
from sidewalk.launcher import RunConfig, build_plans, mission_path, prepare_run
from sidewalk.system import SystemRun

DATA = Path(__file__).parent / "data"
ALL = ("blackboard", "sim", "helm", "pilot", "map_navigator", "captain")


async def _system(tmp_path: Path, mission: str) -> tuple[SystemRun, str]:
    cfg = RunConfig(world="campus", mission=mission, rtf=25.0, seed=5, out=tmp_path, perception=False)
    setup = prepare_run(cfg)
    ns = f"fault{free_port()}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    system = SystemRun(build_plans(cfg, setup, ns, endpoint), ns=ns, endpoint=endpoint, log_dir=tmp_path / "logs")
    await system.start()
    return system, mission_path(mission).read_text()


@pytest.mark.e2e
@pytest.mark.timeout(300)
async def test_killing_the_pilot_leaves_the_others_up_and_the_mission_resumes_or_fails_with_a_reason(tmp_path):
    system, text = await _system(tmp_path, str(DATA / "short-hop.yaml"))
    try:
        mid = await system.submit(text)
        await system.wait_status(mid, lambda s: s.state == "running", timeout=60)
        # let the vehicle get going before the fault
        loop = asyncio.get_running_loop()
        end = loop.time() + 60
        while system.recorder.distance_m() < 5.0 and loop.time() < end:
            await system.next_status(mid, timeout=0.5)
        assert system.recorder.distance_m() >= 5.0, "the vehicle never started moving"
        await system.kill("pilot")
        assert system.crashed() == ["pilot"]
        assert all(system.alive(n) for n in ALL if n != "pilot")
        await system.restart("pilot")
        final = await system.wait_status(mid, lambda s: s.terminal, timeout=180)
        if final.state != "succeeded":
            assert final.reason, "a failed mission must say why"
        assert all(system.alive(n) for n in ALL)
        assert system.crashed() == []
    finally:
        codes = await system.close()
    assert all(c == 0 for c in codes.values()), codes


@pytest.mark.e2e
@pytest.mark.timeout(300)
async def test_unknown_place_fails_the_step_with_its_reason_and_the_next_mission_runs(tmp_path):
    bad = tmp_path / "nowhere.yaml"
    bad.write_text("mission: nowhere\nworld: campus\nsteps:\n  - name: to atlantis\n    destination: atlantis\n")
    system, text = await _system(tmp_path / "run", str(DATA / "short-hop.yaml"))
    try:
        mid = await system.submit(bad.read_text())
        final = await system.wait_status(mid, lambda s: s.terminal, timeout=60)
        assert final.state == "failed" and "atlantis" in final.reason
        mid2 = await system.submit(text)
        st = await system.wait_status(mid2, lambda s: s.state == "running" or s.terminal, timeout=60)
        assert st.state == "running", st.reason
        assert all(system.alive(n) for n in ALL)
    finally:
        await system.close()
