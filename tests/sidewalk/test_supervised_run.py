"""The supervisor of a run keeps its modules running (real processes, real Zenoh on loopback): a
SIGSTOPped HELM is reported wedged within 3 s and restarted, and the mission truly arrives; a MAP
NAVIGATOR whose map file vanished crash-loops, is backed off and given up on, and the CAPTAIN fails
the mission naming the module it waited for."""

import asyncio
import json
import os
import shutil
import signal
import time

import pytest

from sidewalk.codger_run import build_plans
from sidewalk.launcher import RunConfig, mission_path, prepare_run, record_run
from sidewalk.report import build_report, write_report
from sidewalk.supervisor import RestartPolicy
from sidewalk.system import SystemRun
from tests.sidewalk._mission import drive_to
from tests.sidewalk.test_e2e_faults import DATA
from vehicle_sim.worldfile import world_path
from wire.ports import free_port


async def _supervised(cfg: RunConfig, policy: RestartPolicy):
    """Start the run's processes, guard them under `policy`; return the system, the setup and the notice events."""
    setup = prepare_run(cfg)
    ns = f"sup{free_port()}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    system = SystemRun(build_plans(cfg, setup, ns, endpoint), ns=ns, endpoint=endpoint, log_dir=cfg.out / "logs")
    seen = {"wedged": asyncio.Event(), "restarted": asyncio.Event(), "gave up": asyncio.Event()}
    when: dict[str, float] = {}

    def note(text: str) -> None:
        for word, ev in seen.items():
            if word in text and not ev.is_set():
                when[word] = time.monotonic()
                ev.set()

    system.sup.on_notice = note
    try:
        await system.start(ready_timeout=120.0)
        system.guard(policy)
    except BaseException:
        await system.close()
        raise
    return system, setup, seen, when


@pytest.mark.missions
@pytest.mark.e2e
@pytest.mark.timeout(400)  # as the other HELM fault test: six processes start one by one on a loaded machine
async def test_a_sigstopped_helm_is_reported_wedged_within_3_s_restarted_and_the_mission_arrives(tmp_path, capsys):
    cfg = RunConfig(world="campus", mission=str(DATA / "short-hop-dead-reckoning.yaml"), rtf=10.0, seed=5, out=tmp_path, perception=False)
    system, setup, seen, when = await _supervised(cfg, RestartPolicy())
    try:
        mid = await system.submit(mission_path(cfg.mission).read_text())
        await system.wait_status(mid, lambda s: s.state == "running", timeout=60)
        await drive_to(system, mid, 5.0)
        helm = system.sup.procs["helm"]
        old_pid = helm.pid
        t_stop = time.monotonic()
        os.kill(old_pid, signal.SIGSTOP)
        try:
            await asyncio.wait_for(seen["wedged"].wait(), 30)  # the notice reaches this loop when it gets round to it
        except TimeoutError:
            sup = system.sup
            beat = system._beats.newest("helm") if system._beats is not None else None
            raise AssertionError(
                f"no wedge reported 30 s after SIGSTOP of helm pid {old_pid}: newest beat (pid, age s) "
                f"{beat and (beat[0], round(time.monotonic() - beat[1], 2))}, ready_at {helm.ready_at}, exited {helm.exited.is_set()}, "
                f"watch thread alive {sup._watch is not None and sup._watch.is_alive()}, wedges {sup.wedges}, restarts {sup.restarts}, "
                f"guards {sup._guards}, procs {[(n, p.pid) for n, p in sup.procs.items()]}") from None
        # when the supervisor reported it (its own watch thread), not when this busy loop heard of it
        reported_s = system.sup.t0 + system.sup.wedges[0].at_s - t_stop
        await asyncio.wait_for(seen["restarted"].wait(), 90)
        restarted_s = when["restarted"] - t_stop
        final = await system.wait_status(mid, lambda s: s.terminal, timeout=180)
        assert final.state == "succeeded", f"{final.reason}\n{system.sup.tail('helm')}"
        await system.finish(mid)
    finally:
        codes = await system.close()
    with capsys.disabled():
        print(f"\nHELM SIGSTOP -> reported wedged {reported_s:.2f} s, restarted and ready {restarted_s:.2f} s")
    # reported once its heartbeat was 3 s old: at most 3 s after the stop (the last beat came before it)
    (wedge,) = system.sup.wedges
    assert wedge.module == "helm" and wedge.pid == old_pid and 3.0 <= wedge.silent_s < 3.5, wedge
    assert reported_s <= 3.5, reported_s  # 3 s, plus what a loaded machine adds to waking the supervisor
    (restart,) = system.sup.restarts
    assert restart.module == "helm" and restart.reason.startswith("wedged: no heartbeat for 1") and restart.ready
    assert restart.pid != old_pid and restart.delay_s == 0.5
    record = record_run(system, cfg, setup, mid, codes)
    report = build_report(record)
    write_report(report, tmp_path)
    assert report.success and report.claimed_success, report.reason
    saved = json.loads((tmp_path / "report.json").read_text())
    assert [(r["module"], r["reason"][:7]) for r in saved["restarts"]] == [("helm", "wedged:")]
    assert saved["wedges"][0]["module"] == "helm" and saved["gave_up"] == []


@pytest.mark.missions
@pytest.mark.e2e
@pytest.mark.timeout(300)
async def test_a_crash_looping_map_navigator_is_backed_off_given_up_and_the_mission_fails_naming_it(tmp_path):
    own_map = tmp_path / "given-map.geojson"
    shutil.copy(world_path("campus", kind="map"), own_map)
    out = tmp_path / "run"
    cfg = RunConfig(world="campus", mission=str(DATA / "short-hop-dead-reckoning.yaml"), rtf=10.0, seed=5, out=out, perception=False,
                    map_file=own_map)
    system, setup, seen, when = await _supervised(cfg, RestartPolicy(give_up_after=3))
    try:
        mid = await system.submit(mission_path(cfg.mission).read_text())
        await system.wait_status(mid, lambda s: s.state == "running", timeout=60)
        # its map file vanishes and it dies: every new life exits at once
        own_map.unlink()
        os.kill(system.sup.procs["map_navigator"].pid, signal.SIGKILL)
        final = await system.wait_status(mid, lambda s: s.terminal, timeout=120)
        await asyncio.wait_for(seen["gave up"].wait(), 60)
        assert all(system.alive(n) for n in ("blackboard", "helm", "pilot", "captain"))
        await system.finish(mid)
    finally:
        codes = await system.close()
    # the CAPTAIN did not leave the mission running: it failed, naming who went away and what the step waited for
    assert final.state == "failed"
    assert "the MAP NAVIGATOR went away (map_navigator stopped" in final.reason and "step 1" in final.reason, final.reason
    # three restarts, each after a longer back-off, none ready; then the supervisor gave up
    assert [r.delay_s for r in system.sup.restarts] == [0.5, 1.0, 2.0]
    assert [r.ready for r in system.sup.restarts] == [False, False, False]
    assert system.sup.restarts[0].reason == "exited with code -9"
    assert all("exited with code" in r.reason for r in system.sup.restarts)
    starts = [r.at_s for r in system.sup.restarts]
    assert starts[1] - starts[0] >= 1.0 and starts[2] - starts[1] >= 2.0, starts
    (gave,) = system.sup.gave_up
    assert gave.module == "map_navigator" and gave.failures == 3 and "before it was ready" in gave.reason
    assert "map" in system.sup.tail("map_navigator").lower()  # its log says why it cannot start
    report = build_report(record_run(system, cfg, setup, mid, codes))
    write_report(report, out)
    saved = json.loads((out / "report.json").read_text())
    assert [r["module"] for r in saved["restarts"]] == ["map_navigator"] * 3
    assert saved["gave_up"][0]["module"] == "map_navigator"
