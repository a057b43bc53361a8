"""`sidewalk run --arch eddie --secure DIR`: EDDIE's processes under TLS, passwords and the router's access control.

The run's own processes (router, simulator, controller, navigator, map manager and mission service,
which drives the route through the controller: no perception, to keep the test light) start secure,
each as its own role. The perception modules' credentials are used by the test itself. Before
the mission, every EDDIE module's credentials but the controller's try to drive: none of their
commands reaches the simulator's drive key (an `evaluation` reader hears the controller's own test
command put after theirs, and the vehicle stays where it is by truth). Then the mission is
submitted as the operator and the controller drives the vehicle (truth).
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from sidewalk.eddie_run import EddieSystemRun, compile_annotated_map, eddie_plans
from sidewalk.launcher import RunConfig, prepare_run
from sidewalk.security import init_secure_dir
from wire.drive import DriveCommand, decode, encode
from wire.keys import SimKeys
from wire.network import NetworkConfig, SecureConfig
from wire.ports import free_port
from wire.session import open_session

pytestmark = pytest.mark.e2e

MISSION = Path(__file__).parent / "data" / "short-hop.yaml"
INTRUDERS = ("navigator", "map_manager", "mission_service", "road_following", "landmark_matching", "obstacle_stop")
MARK = 0.777  # [m/s] the intruders' speed: no module commands it


@pytest.mark.missions
@pytest.mark.timeout(480)
async def test_an_eddie_run_under_secure_drives_and_only_the_controller_may(tmp_path) -> None:
    d = tmp_path / "sec"
    init_secure_dir(d)
    ns = "eddiesec"
    cfg = RunConfig(world="campus", mission=str(MISSION), out=tmp_path, namespace=ns, arch="eddie", record=False, perception=False,
                    secure=d, rtf=4.0)
    setup = prepare_run(cfg)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    plans = eddie_plans(cfg, setup, ns, endpoint, annotated_map=compile_annotated_map(setup, tmp_path))
    assert all("--secure" in p.args for p in plans)
    system = EddieSystemRun(plans, ns=ns, endpoint=endpoint, log_dir=tmp_path / "logs", secure=d)
    keys = SimKeys(ns)
    sessions = []
    try:
        await system.start()
        assert system.recorder is not None and system.link is not None
        loop = asyncio.get_running_loop()
        heard: list[DriveCommand] = []
        control = asyncio.Event()

        def on_cmd(_key: str, payload: bytes) -> None:
            cmd = decode(DriveCommand, payload)
            heard.append(cmd)
            if cmd.seq == 10_000_000:
                loop.call_soon_threadsafe(control.set)

        system.link.subscribe(keys.cmd, on_cmd)  # the run's observer: role `evaluation`, which reads everything
        for role in (*INTRUDERS, "controller"):
            s = open_session(NetworkConfig(namespace=ns, connect=(endpoint,), secure=SecureConfig(dir=d, role=role)))
            s.wait_connected(timeout=10, name=role)
            sessions.append((role, s))
        for round_ in range(50):
            for i, (role, s) in enumerate(sessions[:-1]):
                s.put(keys.cmd, encode(DriveCommand(speed=MARK, curvature=0.0, seq=1000 * round_ + i + 1)))
            # the controller's credentials, after the intruders': once this is heard, theirs would have been
            sessions[-1][1].put(keys.cmd, encode(DriveCommand(speed=0.0, curvature=0.0, seq=10_000_000)))
            try:
                await asyncio.wait_for(control.wait(), 0.2)
                break
            except asyncio.TimeoutError:
                continue
        assert control.is_set(), "the controller's credentials could not publish a drive command"
        assert not [c for c in heard if c.speed == pytest.approx(MARK)], "a module other than the controller drove"
        # truth, over the intruders' commands and one more second of sim time: the vehicle did not move
        await system.recorder.wait_rest(still_s=1.0)
        assert system.recorder.truth.rows and system.recorder.distance_m() < 0.05

        mission_id = await system.submit(setup.mission_file.read_text())  # as the operator
        while system.recorder.distance_m() < 5.0:
            st = await system.next_status(mission_id, timeout=0.5)
            assert st is None or not st.terminal or system.recorder.distance_m() >= 5.0, st
            assert system.stamps()[1] < system.submitted[mission_id][1] + 200.0, "the vehicle did not drive 5 m in 200 s sim"
        assert system.crashed() == []
    finally:
        for _role, s in sessions:
            s.close()
        await system.close()
