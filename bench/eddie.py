"""EDDIE benchmark: the controller's position queries beside the raw-Zenoh get floor of the same run.

Processes on loopback: the simulator (as the router), the controller (`python -m eddie.controller`)
and a floor process (`python -m bench.eddie floor`) whose plain queryable answers at once, on the
Zenoh thread, with as many bytes as a position reply. This process asks both through the same
session and asyncio harness (`wire.aio.Link.get` under `eddie.toolkit.Module.request`), interleaved.

Keys: position_query_p50_us/p99 vs zenoh_get_p50_us/p99, their ratio position_query_vs_zenoh_get,
and trigger_latency_p50_ms (the annotated map manager's trigger: the crossing in sim to the
message's arrival at its destination, wall time) — null until `measure_trigger_latency` is filled.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import select
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from wire.keys import Keys
from wire.network import NetworkConfig
from wire.ports import free_port
from wire.session import open_session

from eddie.messages.controller import Position, PositionQuery
from eddie.toolkit import Module
from eddie.toolkit.message import encode_envelope

__all__ = ["run", "measure_trigger_latency", "FLOOR_READY"]

ROOT = Path(__file__).resolve().parents[1]
#: The floor process's ready line.
FLOOR_READY = "floor ready"


def _pct(xs: list[float]) -> tuple[float, float]:
    a = np.asarray(xs)
    return float(np.percentile(a, 50)), float(np.percentile(a, 99))


def _floor_main(endpoint: str, ns: str, size: int) -> None:
    """Answer `bench/eddie-floor` with `size` bytes at once, on the Zenoh thread (no asyncio)."""
    s = open_session(NetworkConfig(namespace=ns, connect=(endpoint,)))
    payload = b"x" * size

    def on_query(q) -> None:  # noqa: ANN001 - wire.session.Query
        q.reply(payload)
        q.finish()

    try:
        s.queryable(Keys(ns).bench("eddie-floor"), on_query)
        s.wait_connected(10.0, name="floor")
        print(FLOOR_READY, flush=True)
        stop = threading.Event()
        signal.signal(signal.SIGTERM, lambda *_: stop.set())  # close the session on the way out
        try:
            while not stop.wait(1.0):
                if os.getppid() == 1:
                    break
        except KeyboardInterrupt:
            pass
    finally:
        s.close()


def _spawn(args: list[str], ready: str, timeout: float = 60.0) -> subprocess.Popen:
    p = subprocess.Popen([sys.executable, *args], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                         env=dict(os.environ, PYTHONUNBUFFERED="1"))
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        r, _, _ = select.select([p.stdout], [], [], max(0.0, deadline - time.monotonic()))
        if not r:
            break
        line = p.stdout.readline()
        if not line:
            break
        if ready in line:
            return p
    p.kill()
    p.wait(10)
    raise RuntimeError(f"{args[:3]} did not start (no {ready!r})")


def _stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        p.terminate()
        try:
            p.wait(15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(5)
    if p.stdout is not None:
        p.stdout.close()


def measure_trigger_latency(net: NetworkConfig, samples: int) -> float | None:
    """Return the trigger latency p50 [ms] (crossing in sim → arrival at the destination, wall), or None.

    Hook for the annotated map manager's benchmark (helper eddie-maps): None until it is filled.
    """
    return None


async def _bench(ns: str, ep: str, samples: int) -> dict:
    net = NetworkConfig(namespace=ns, connect=(ep,))
    async with Module("bench", net) as me:
        await me.wait_connected(10.0)
        deadline = time.monotonic() + 30.0
        while True:  # the controller answers once it has odometry
            try:
                first = await me.request("controller", "position", PositionQuery(), timeout=2.0, reply_type=Position)
                break
            except Exception:  # noqa: BLE001 - not up yet
                if time.monotonic() > deadline:
                    raise
                await asyncio.sleep(0.1)
        floor_key = Keys(ns).bench("eddie-floor")
        query = encode_envelope("bench", PositionQuery(), None)
        size = len(encode_envelope("controller", first, first.stamp))
        pos_us: list[float] = []
        floor_us: list[float] = []
        for _ in range(50):  # warm-up
            await me.request("controller", "position", PositionQuery(), timeout=2.0)
            await me.link.get(floor_key, query, timeout=2.0)
        for _ in range(samples):
            t0 = time.perf_counter()
            await me.request("controller", "position", PositionQuery(), timeout=2.0, reply_type=Position)
            t1 = time.perf_counter()
            replies = await me.link.get(floor_key, query, timeout=2.0)
            t2 = time.perf_counter()
            if not replies or not replies[0].ok:
                raise RuntimeError("the floor process did not answer")
            pos_us.append((t1 - t0) * 1e6)
            floor_us.append((t2 - t1) * 1e6)
    p50, p99 = _pct(pos_us)
    f50, f99 = _pct(floor_us)
    return {
        "position_query_p50_us": p50, "position_query_p99_us": p99,
        "zenoh_get_p50_us": f50, "zenoh_get_p99_us": f99,
        "position_query_vs_zenoh_get": p50 / f50 if f50 > 0 else None,
        "position_reply_bytes": size, "samples": samples,
    }


def run(samples: int = 2000) -> dict:
    """Start simulator, controller and floor on loopback; return the benchmark's figures."""
    ns = f"benchedd{os.getpid()}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    procs: list[subprocess.Popen] = []
    try:
        procs.append(_spawn(["-m", "sidewalk", "sim", "serve", "--world", "campus", "--vehicle", "navlab", "--seed", "1",
                             "--ns", ns, "--mode", "router", "--listen", ep], "ready sim"))
        procs.append(_spawn(["-m", "eddie.controller", "--vehicle", "navlab", "--ns", ns, "--connect", ep],
                            "SIDEWALK-READY controller"))
        size = len(encode_envelope("controller", Position(stamp=1.0, x=1.0, y=1.0, yaw=1.0, v=1.0), 1.0))
        procs.append(_spawn(["-m", "bench.eddie", "floor", "--endpoint", ep, "--ns", ns, "--size", str(size)], FLOOR_READY))
        out = asyncio.run(_bench(ns, ep, samples))
        out["trigger_latency_p50_ms"] = measure_trigger_latency(NetworkConfig(namespace=ns, connect=(ep,)), samples)
        return out
    finally:
        for p in reversed(procs):
            _stop(p)


def main(argv: list[str] | None = None) -> int:
    """`python -m bench.eddie floor …` (the floor process) or `python -m bench.eddie` (the benchmark, JSON)."""
    ap = argparse.ArgumentParser(prog="python -m bench.eddie")
    ap.add_argument("what", nargs="?", default="run", choices=["run", "floor"])
    ap.add_argument("--endpoint", default="")
    ap.add_argument("--ns", default="")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--samples", type=int, default=2000)
    args = ap.parse_args(argv)
    if args.what == "floor":
        _floor_main(args.endpoint, args.ns, args.size)
        return 0
    import json

    print(json.dumps(run(args.samples), sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
