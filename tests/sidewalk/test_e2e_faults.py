"""Faults across processes: a killed PILOT comes back, resumes and the mission truly arrives; a bad
mission fails with its reason and the next one runs. Real processes, real Zenoh on loopback."""

import asyncio
from pathlib import Path

import pytest

from sidewalk.codger_run import build_plans
from sidewalk.launcher import RunConfig, RunSetup, mission_path, prepare_run, record_run
from sidewalk.report import build_report
from sidewalk.run_record import save_record
from sidewalk.system import SystemRun
from wire.ports import free_port

DATA = Path(__file__).parent / "data"
ALL = ("blackboard", "sim", "helm", "pilot", "map_navigator", "captain")


async def _system(tmp_path: Path, mission: str, *, rtf: float = 25.0, ready_timeout: float = 60.0) -> tuple[SystemRun, str, RunConfig, RunSetup]:
    # a restarted PILOT may take long to come back on a loaded machine: the MAP NAVIGATOR waits for it
    # perception off: a mission judged by truth here is the dead-reckoning short hop (2 m of room, see its file)
    cfg = RunConfig(world="campus", mission=mission, rtf=rtf, seed=5, out=tmp_path, perception=False, pilot_grace_s=120.0)
    setup = prepare_run(cfg)
    ns = f"fault{free_port()}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    system = SystemRun(build_plans(cfg, setup, ns, endpoint), ns=ns, endpoint=endpoint, log_dir=tmp_path / "logs")
    try:
        await system.start(ready_timeout=ready_timeout)
    except BaseException:
        await system.close()  # a process that did not come up: stop the ones that did
        raise
    return system, mission_path(mission).read_text(), cfg, setup


@pytest.mark.missions
@pytest.mark.e2e
@pytest.mark.timeout(300)
async def test_a_killed_pilot_is_restarted_resumes_and_the_mission_truly_arrives(tmp_path):
    system, text, cfg, setup = await _system(tmp_path, str(DATA / "short-hop-dead-reckoning.yaml"))
    try:
        mid = await system.submit(text)
        await system.wait_status(mid, lambda s: s.state == "running", timeout=60)
        # let the vehicle get going before the fault
        loop = asyncio.get_running_loop()
        end = loop.time() + 60
        while system.recorder.distance_m() < 5.0 and loop.time() < end:
            await system.next_status(mid, timeout=0.5)
        assert system.recorder.distance_m() >= 5.0, "the vehicle never started moving"
        # the first PILOT's cost is known only once one of its heartbeats (1 Hz wall) was heard
        while not any(name == "pilot" for name, _pid in system.recorder.costs) and loop.time() < end:
            await system.next_status(mid, timeout=0.2)
        await system.kill("pilot")
        assert system.crashed() == ["pilot"]
        assert all(system.alive(n) for n in ALL if n != "pilot")
        driven_at_kill = system.recorder.distance_m()
        await system.restart("pilot")
        final = await system.wait_status(mid, lambda s: s.terminal, timeout=180)
        assert final.state == "succeeded", f"the mission did not finish after the restart: {final.reason}"
        assert all(system.alive(n) for n in ALL)
        assert system.crashed() == []
        await system.finish(mid)
    finally:
        codes = await system.close()
    assert all(c == 0 for c in codes.values()), codes
    record = record_run(system, cfg, setup, mid, codes)
    save_record(record, tmp_path / "run_record.json")  # to look at when this fails
    report = build_report(record)
    # the restarted PILOT drove on: the vehicle truly reached the hall, without a collision
    assert report.success and report.claimed_success, report.reason
    assert report.steps[0].distance_m is not None and report.steps[0].distance_m <= report.steps[0].tolerance_m
    assert report.distance_m > driven_at_kill + 20.0
    assert report.collisions == 0
    # both lives of the PILOT are in its cost
    assert report.modules["pilot"].incarnations == 2


@pytest.mark.e2e
@pytest.mark.timeout(300)
async def test_unknown_place_is_refused_at_submit_with_its_reason_and_the_next_mission_runs(tmp_path):
    from sidewalk.mission_client import MissionRejected

    bad = tmp_path / "nowhere.yaml"
    bad.write_text("mission: nowhere\nworld: campus\nsteps:\n  - name: to atlantis\n    destination: atlantis\n")
    system, text, _, _ = await _system(tmp_path / "run", str(DATA / "short-hop.yaml"))
    try:
        with pytest.raises(MissionRejected) as exc:
            await system.submit(bad.read_text())
        (problem,) = exc.value.rejection.problems
        assert problem.field == "steps[0].destination" and "unknown place 'atlantis'" in problem.message
        assert "quad" in problem.message  # the places it does know
        mid2 = await system.submit(text)
        st = await system.wait_status(mid2, lambda s: s.state == "running" or s.terminal, timeout=60)
        assert st.state == "running", st.reason
        assert all(system.alive(n) for n in ALL)
    finally:
        await system.close()
