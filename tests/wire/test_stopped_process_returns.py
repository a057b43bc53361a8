"""A process stopped past its lease and continued is heard again, both ways, by a session up the whole time.

The deployment's own defaults (`wire.flags`): a module started with `--connect ROUTER` and the
observer's session are clients of the router. As peers linked directly they were not: a peer up all
the while could lose the continued process for good (eclipse-zenoh/zenoh#498; before session 25 a
reproduction of this test lost it in the first cycle, 6 times of 6). Twenty cycles, each past the
stopped process's lease (3 s, `--lease`: the same expiry as Zenoh's default 10 s, sooner): a `missions` test.
"""

from __future__ import annotations

import asyncio
import os
import signal
import sys
import time

import pytest

from eddie.toolkit import Module
from eddie.toolkit.echo import Echo
from tests._procs import wait_stopped
from tests.modules._procs import spawn, stop
from wire.flags import FlagError, network_config
from wire.keys import ModuleKeys
from wire.ports import free_port
from wire.session import open_session

CYCLES = 20
NS = f"lease{os.getpid()}"
LEASE_S = 3.0  # the stopped process's: the router drops it after so long


@pytest.mark.missions
@pytest.mark.timeout(480)  # ~100 s measured busy (20 cycles past a 3-s lease; 260 s with Zenoh's 10 s)
async def test_a_process_stopped_past_its_lease_is_heard_again_twenty_times_of_twenty():
    ep = f"tcp/127.0.0.1:{free_port()}"
    router = spawn([sys.executable, "-m", "sidewalk", "up", "router", "--ns", NS, "--listen", ep], "router ready")
    net = network_config(ns=NS, connect=[ep], listen=None, mode=None, role="peer")
    assert net.mode == "client"  # what every process of a system is by default
    keys = ModuleKeys(NS)
    loop = asyncio.get_running_loop()
    beats: list[float] = []
    beat = asyncio.Event()
    alive = {"up": asyncio.Event(), "down": asyncio.Event()}

    def on_beat(_key: str, _payload: bytes) -> None:
        loop.call_soon_threadsafe(lambda: (beats.append(time.monotonic()), beat.set()))

    def on_alive(_key: str, up: bool) -> None:
        loop.call_soon_threadsafe(alive["up" if up else "down"].set)

    target = None
    heard: list[tuple[float, float, float]] = []
    try:
        async with Module("observer", net) as me:
            await me.wait_connected(10.0)
            s = open_session(net)  # the same Zenoh session as the observer module's: up the whole time
            try:
                s.subscribe_payload(keys.heartbeat("target"), on_beat)
                s.liveliness_subscribe(keys.alive("target"), on_alive, history=True)
                target = spawn([sys.executable, "-m", "eddie.toolkit.echo", "target", "--ns", NS, "--connect", ep,
                                "--lease", str(LEASE_S)], "SIDEWALK-READY")
                await asyncio.wait_for(alive["up"].wait(), 30)
                for cycle in range(CYCLES):
                    beat.clear()
                    await asyncio.wait_for(beat.wait(), 30)  # beating before the stop
                    alive["down"].clear()
                    alive["up"].clear()
                    os.kill(target.pid, signal.SIGSTOP)
                    wait_stopped(target.pid)
                    try:
                        # past its lease: the router dropped it, and the observer heard that
                        await asyncio.wait_for(alive["down"].wait(), 60)
                    finally:
                        os.kill(target.pid, signal.SIGCONT)
                    t_cont = time.monotonic()
                    beat.clear()
                    await asyncio.wait_for(alive["up"].wait(), 30)
                    t_alive = time.monotonic() - t_cont
                    while not beats or beats[-1] <= t_cont:  # a heartbeat published after the continue
                        beat.clear()
                        await asyncio.wait_for(beat.wait(), 30)
                    t_beat = beats[-1] - t_cont
                    # and the other way: the continued process answers the observer
                    reply = await me.request("target", "echo", Echo(seq=cycle, data=b"back"), timeout=10.0, reply_type=Echo)
                    assert reply == Echo(seq=cycle, data=b"back")
                    heard.append((t_alive, t_beat, time.monotonic() - t_cont))
            finally:
                s.close()
    finally:
        if target is not None:
            stop(target)
        stop(router)
    assert len(heard) == CYCLES
    worst = max(h[2] for h in heard)
    print(f"\n{CYCLES}/{CYCLES} heard again; after SIGCONT: token back ≤ {max(h[0] for h in heard):.2f} s, "
          f"heartbeat ≤ {max(h[1] for h in heard):.2f} s, echo answered ≤ {worst:.2f} s")


def test_every_process_of_a_system_is_a_client_of_the_router_unless_it_listens_or_says_otherwise(monkeypatch):
    for var in ("SIDEWALK_MODE", "SIDEWALK_CONNECT", "SIDEWALK_LISTEN", "SIDEWALK_SECURE"):
        monkeypatch.delenv(var, raising=False)
    ep = ["tcp/10.0.0.2:7447"]
    module = network_config(ns=NS, connect=ep, listen=None, mode=None, role="peer")
    assert module.mode == "client" and module.zenoh_json()["mode"] == "client" and "listen" not in module.zenoh_json()
    assert network_config(ns=NS, connect=None, listen=None, mode=None, role="peer").mode == "client"  # the default endpoint
    assert network_config(ns=NS, connect=None, listen=ep, mode=None, role="peer").mode == "peer"  # others connect to it
    assert network_config(ns=NS, connect=ep, listen=None, mode="peer", role="peer").mode == "peer"  # asked for
    monkeypatch.setenv("SIDEWALK_MODE", "peer")
    assert network_config(ns=NS, connect=ep, listen=None, mode=None, role="peer").mode == "peer"
    assert network_config(ns=NS, connect=ep, listen=None, mode=None, role="tool").mode == "peer"
    monkeypatch.delenv("SIDEWALK_MODE")
    assert network_config(ns=NS, connect=ep, listen=None, mode=None, role="tool").mode == "client"
    assert network_config(ns=NS, connect=None, listen=None, mode=None, role="router").mode == "router"


def test_the_lease_flag_sets_the_lease_the_session_announces_and_refuses_nonsense(monkeypatch):
    monkeypatch.delenv("SIDEWALK_LEASE", raising=False)
    monkeypatch.delenv("SIDEWALK_SECURE", raising=False)
    ep = ["tcp/10.0.0.2:7447"]
    assert "transport" not in network_config(ns=NS, connect=ep, listen=None, mode=None, role="peer").zenoh_json()
    net = network_config(ns=NS, connect=ep, listen=None, mode=None, role="peer", lease="2.5")
    assert net.lease_s == 2.5 and net.zenoh_json()["transport"]["link"]["tx"]["lease"] == 2500
    monkeypatch.setenv("SIDEWALK_LEASE", "4")  # the environment, as every process a run starts inherits it
    assert network_config(ns=NS, connect=ep, listen=None, mode=None, role="peer").zenoh_json()["transport"]["link"]["tx"] == {"lease": 4000}
    for bad in ("soon", "0.1"):
        with pytest.raises(FlagError, match="--lease"):
            network_config(ns=NS, connect=ep, listen=None, mode=None, role="peer", lease=bad)
