"""Faults survived, in one mission (real processes, real Zenoh on loopback): the blackboard node is
SIGKILLed and restarted on the same database mid-mission, then the HELM is SIGSTOPped until its
liveliness lease expires (the node drops its monitors) and SIGCONTed. Every module re-registers what
it lost, the vehicle stands still while the HELM is stopped, the HELM is judged wedged meanwhile (as
`sidewalk status` judges it), and the mission truly arrives (`success` judged from truth)."""

import asyncio
import os
import re
import signal
import time

import pytest

from sidewalk.health import WEDGED_AFTER_S, ModuleHealth, collect_heartbeats
from sidewalk.launcher import record_run
from sidewalk.report import build_report
from sidewalk.run_record import save_record
from tests.sidewalk._mission import drive_to
from tests.sidewalk.test_e2e_faults import DATA, _system
from wire.keys import ModuleKeys, SimKeys

MODULES = ("helm", "pilot", "map_navigator", "captain")


@pytest.mark.missions
@pytest.mark.e2e
@pytest.mark.timeout(400)
async def test_node_restart_and_a_wedged_helm_are_survived_and_the_mission_truly_arrives(tmp_path, capsys):
    # at a lower RTF the sim-time bounds (the PILOT's stuck timer) leave a loaded machine more wall time
    system, text, cfg, setup = await _system(tmp_path, str(DATA / "short-hop-dead-reckoning.yaml"), rtf=10.0,
                                             ready_timeout=120.0)
    keys = ModuleKeys(system.ns)
    loop = asyncio.get_running_loop()
    try:
        mid = await system.submit(text)
        await system.wait_status(mid, lambda s: s.state == "running", timeout=60)
        await drive_to(system, mid, 5.0)

        # ---- 1. the blackboard node killed and restarted on the same database
        await system.kill("blackboard")
        await system.restart("blackboard")
        t_back = time.monotonic()
        # every module says (in its heartbeat) its link is up again after re-registering its monitors
        while True:
            beats = await collect_heartbeats(system.link, keys, set(MODULES), 10.0)
            recovered = {n for n in MODULES if n in beats and (beats[n].beat.resyncs or 0) >= 1
                         and beats[n].beat.blackboard == "up"}
            if recovered == set(MODULES) or time.monotonic() - t_back > 60:
                break
        assert recovered == set(MODULES), {n: beats[n].beat for n in beats}
        resync_s = time.monotonic() - t_back
        stats = await system.blackboard_stats()
        held = sum(beats[n].beat.monitors or 0 for n in MODULES)
        assert held > 0 and stats is not None and stats.monitors >= held, (held, stats)
        assert all(system.alive(n) for n in MODULES)
        driven = system.recorder.distance_m()
        await drive_to(system, mid, driven + 5.0)  # and the vehicle drives on

        # ---- 2. the HELM stopped past its liveliness lease, then continued
        helm_pid = system.sup.procs["helm"].proc.pid
        gone = asyncio.Event()
        watch = system.link.watch_alive(keys.alive("helm"), lambda _k, alive: None if alive else gone.set(), history=False)
        commands: list[float] = []
        cmd_sub = system.link.subscribe(SimKeys(system.ns).cmd, lambda _k, _p: commands.append(time.monotonic()))
        os.kill(helm_pid, signal.SIGSTOP)
        try:
            # what `sidewalk status` does: alive by its token, silent for 3 s → wedged
            assert await system.link.alive_keys(keys.alive("helm"))
            beats = await collect_heartbeats(system.link, keys, {"helm", "pilot"}, WEDGED_AFTER_S + 0.5)
            helm = ModuleHealth.judge("helm", beats.get("helm"), time.time(), listened_s=WEDGED_AFTER_S + 0.5)
            assert helm.state == "wedged", helm
            # the vehicle stops: its timed drive commands run out
            stopped = await system.recorder.wait_rest(still_s=1.0, max_sim_s=1e9, max_wall_s=30.0)
            assert stopped is not None, "the vehicle kept moving while the HELM was stopped"
            # keep it stopped until the node dropped it (its lease expired): it must re-register on return
            await asyncio.wait_for(gone.wait(), 40)
            assert system.recorder.rest_since(1.0) is not None
        finally:
            commands.clear()
            t_cont = time.monotonic()
            left_m = system.recorder.distance_m()
            os.kill(helm_pid, signal.SIGCONT)
        system.link.undeclare(watch)
        final = await system.wait_status(mid, lambda s: s.terminal, timeout=240)
        system.link.undeclare(cmd_sub)
        assert final.state == "succeeded", f"{final.reason}\n{system.sup.tail('helm')}"
        # the continued HELM drives on — unless the vehicle had already covered the route when it stopped
        # (short-hop is short: the second leg can end at the goal), which the truth verdict below checks
        # Only the HELM drives in CODGER, so the truth moving after SIGCONT is its commands reaching the
        # simulator. The observer's own subscription to them is a figure, not the evidence: once in CI
        # (9247bd6) the vehicle drove 36 m after SIGCONT and the observer heard none of the commands, its
        # route to the re-connected HELM apparently not re-declared after the lease drop.
        # A HELM that stayed silent short of the goal fails the mission (no progress), asserted just above and
        # by truth below; the distance it drove after SIGCONT is printed.
        moved_m = system.recorder.distance_m() - left_m
        cont_s = commands[0] - t_cont if commands else float("nan")
        # the HELM resynced at least once (the node restart; the lease drop adds one when the node saw it go),
        # and the node holds every monitor the modules say they have: nothing lost stays lost
        #
        # The observer's session, up all along, hears the continued HELM again: every process is a client of the
        # router (wire.flags). Twice in CI (9247bd6, 52bdabf), when they were peers linked directly, it heard
        # nothing the continued HELM published while the simulator and the node did (eclipse-zenoh/zenoh#498).
        helm_log = system.sup.tail("helm", 500)
        registered = re.findall(r"re-registered (\d+) monitors", helm_log)
        assert registered, f"the HELM never re-registered its monitors:\n{helm_log[-3000:]}"
        beats = await collect_heartbeats(system.link, keys, set(MODULES), 10.0)
        heard_helm = "helm" in beats
        assert heard_helm, f"the observer did not hear the continued HELM beat within 10 s: heard {sorted(beats)}"
        assert (beats["helm"].beat.resyncs or 0) >= 1, beats["helm"].beat
        stats = await system.blackboard_stats()
        held = sum(beats[n].beat.monitors or 0 for n in MODULES)
        assert stats is not None and stats.monitors >= held, (held, stats)
        assert all(system.alive(n) for n in MODULES)
        await system.finish(mid)
    finally:
        codes = await system.close()
    with capsys.disabled():
        print(f"\nrecovery: node restart ready -> every module re-registered {resync_s:.2f} s; "
              f"HELM SIGCONT -> first drive command {cont_s:.2f} s (heard {len(commands)}), then drove {moved_m:.1f} m; "
              f"its heartbeat heard after: {heard_helm}")
    record = record_run(system, cfg, setup, mid, codes)
    save_record(record, tmp_path / "run_record.json")
    report = build_report(record)
    assert report.success and report.claimed_success, report.reason
    assert report.collisions == 0
    assert report.modules["blackboard"].incarnations == 2
