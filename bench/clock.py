"""Clock benchmark: what a module costs while it only waits, with the simulator ticking at a high RTF.

Processes on loopback: the simulator (`sidewalk sim serve`, as the router) at `rtf`, and this one.
The simulator announces sim time every physics step (20 Hz sim on the Terregator: 1000 ticks a
second of wall time at RTF 50), and every module hears every tick. Measured one after the other in
this process, each for `seconds` [s wall], as CPU time of the whole process (Zenoh's threads
included) per wall second [core]:

- `zenoh_subscriber_cpu_core`: the floor, a bare subscription to the clock whose callback does nothing;
- `module_waiting_cpu_core`: an EDDIE module (`eddie.toolkit.Module`: clock, inbox, heartbeat) that
  waits for nothing but wall time;
- `module_napping_cpu_core`: the same module napping `nap_s` [s sim] in a loop (`clock.sleep`), as a
  switched module's cycle does;
- `codger_waiting_cpu_core`: a CODGER module (`runtime.run_module`) that waits.

Beside them `clock_ticks_per_s` [1/s wall] and `naps_per_s` [1/s wall]. A module that waits
should cost what the floor does: the ticks it hears, nothing more.
"""

from __future__ import annotations

import asyncio
import os
import sys
import threading
import time

from bench.eddie import _spawn, _stop
from bench.errors import BenchError
from wire.keys import ModuleKeys
from wire.network import NetworkConfig
from wire.ports import free_port
from wire.session import open_session

__all__ = ["run"]


def _floor(net: NetworkConfig, seconds: float) -> tuple[float, float]:
    s = open_session(net)
    n = [0]
    ticking = threading.Event()

    def on_tick(_key: str, _payload: bytes) -> None:
        n[0] += 1
        ticking.set()

    try:
        s.subscribe_payload(ModuleKeys(net.namespace).sim_clock, on_tick)
        if not ticking.wait(10.0):
            raise BenchError(f"no sim clock tick within 10 s on {net.connect}")
        c0, t0, n0 = time.process_time(), time.monotonic(), n[0]
        time.sleep(seconds)  # the measured window [s wall]: the process does nothing but hear ticks
        wall = time.monotonic() - t0
        return (time.process_time() - c0) / wall, (n[0] - n0) / wall
    finally:
        s.close()


async def _eddie(net: NetworkConfig, seconds: float, nap_s: float) -> tuple[float, float]:
    from eddie.toolkit import Module

    with open(os.devnull, "w") as devnull:
        async with Module("bench-clock", net, stdout=devnull) as m:
            await m.clock.wait_running(10.0)
            c0, t0, naps = time.process_time(), time.monotonic(), 0
            if nap_s > 0:
                while time.monotonic() - t0 < seconds:
                    await m.clock.sleep(nap_s)
                    naps += 1
            else:
                await asyncio.sleep(seconds)  # the measured window [s wall]
            wall = time.monotonic() - t0
            return (time.process_time() - c0) / wall, naps / wall


def _codger(net: NetworkConfig, seconds: float) -> float:
    from runtime.lifecycle import run_module

    out: list[float] = []

    async def body(rt) -> None:  # noqa: ANN001 - ModuleRuntime
        await rt.clock.wait_running(10.0)
        c0, t0 = time.process_time(), time.monotonic()
        await asyncio.sleep(seconds)  # the measured window [s wall]
        out.append((time.process_time() - c0) / (time.monotonic() - t0))

    with open(os.devnull, "w") as devnull:
        run_module("bench-clock", body, net, install_signals=False, stdout=devnull)
    return out[0]


def run(rtf: float = 50.0, seconds: float = 4.0, nap_s: float = 0.2) -> dict:
    """Start a simulator at `rtf`, measure the waiting costs (see module docstring), stop it; return the figures."""
    if not rtf > 0 or not seconds > 0:
        raise ValueError("rtf and seconds must be positive")
    ns = f"clock{os.getpid()}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    sim = _spawn(["-m", "sidewalk", "sim", "serve", "--world", "campus", "--vehicle", "terregator", "--rtf", str(rtf),
                  "--seed", "0", "--ns", ns, "--mode", "router", "--listen", ep], "ready sim", timeout=180.0)
    net = NetworkConfig(namespace=ns, mode="client", connect=(ep,))  # a client of the router, as a deployed module
    try:
        floor, ticks = _floor(net, seconds)
        waiting, _ = asyncio.run(_eddie(net, seconds, 0.0))
        napping, naps = asyncio.run(_eddie(net, seconds, nap_s))
        codger = _codger(net, seconds)
    finally:
        _stop(sim)
    return {
        "rtf_requested": rtf,
        "clock_ticks_per_s": round(ticks, 1),
        "zenoh_subscriber_cpu_core": round(floor, 4),
        "module_waiting_cpu_core": round(waiting, 4),
        "module_napping_cpu_core": round(napping, 4),
        "naps_per_s": round(naps, 1),
        "nap_s": nap_s,
        "codger_waiting_cpu_core": round(codger, 4),
        "seconds": seconds,
        "cpus": os.cpu_count(),
        "loadavg_1m": round(os.getloadavg()[0], 2),
    }


if __name__ == "__main__":
    from sidewalk.json_out import dumps

    print(dumps(run(*(float(a) for a in sys.argv[1:3])), sort_keys=True))
