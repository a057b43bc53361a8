"""EDDIE benchmark: the controller's position queries beside the raw-Zenoh get floor of the same run.

Processes on loopback: the simulator (as the router), the controller (`python -m eddie.controller`)
and a floor process (`python -m bench.eddie floor`) whose plain queryable answers at once, on the
Zenoh thread, with as many bytes as a position reply; each a client of the router, as a system
deploys them (`wire.flags`; before session 25 they were peers linked directly, one hop less). This process asks both through the same
session and asyncio harness (`wire.aio.Link.get` under `eddie.toolkit.Module.request`), interleaved.

Keys: position_query_p50_us/p99 vs zenoh_get_p50_us/p99, their ratio position_query_vs_zenoh_get,
and trigger_latency_p50_ms (the annotated map manager's trigger: the crossing cycle to the
message's arrival at its destination, wall time; `measure_trigger_latency`).
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

from bench.errors import BenchError
from wire.keys import Keys
from wire.network import NetworkConfig
from wire.ports import free_port
from wire.session import open_session
from wire.summary import percentiles

from eddie.messages.controller import Position, PositionQuery
from eddie.toolkit import Module
from eddie.toolkit.message import encode_envelope

__all__ = ["run", "measure_trigger_latency", "FLOOR_READY"]

ROOT = Path(__file__).resolve().parents[1]
#: The floor process's ready line.
FLOOR_READY = "floor ready"


def _floor_main(endpoint: str, ns: str, size: int) -> None:
    """Answer `bench/eddie-floor` with `size` bytes at once, on the Zenoh thread (no asyncio)."""
    s = open_session(NetworkConfig(namespace=ns, mode="client", connect=(endpoint,)))
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
    raise BenchError(f"{args[:3]} did not start (no {ready!r})")


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


#: Gates the trigger benchmark crosses (one trigger message each).
TRIGGER_SAMPLES_MAX = 300


async def _trigger_bench(net: NetworkConfig, path: Path, n: int) -> dict:
    """Cross `n` gates one by one as fake controller `benchctl` / navigator `benchnav`; time each trigger's arrival."""
    from eddie.messages.controller import ControllerState
    from eddie.messages.map_manager import AnnotationList, AnnotationQuery, TriggerMessage
    from eddie.messages.navigator import WorldFromLocal
    from eddie.errors import LinkTimeout
    from eddie.toolkit.message import encode_body

    async with Module("bench_dest", net) as me:
        await me.wait_connected(10.0)
        deadline = time.monotonic() + 30.0
        while True:  # the answer means the manager's subscriptions are declared (it declares them first)
            try:
                await me.request("map_manager", "query", AnnotationQuery(type="bench"), timeout=2.0, reply_type=AnnotationList)
                break
            except Exception:  # noqa: BLE001 - not up yet
                if time.monotonic() > deadline:
                    raise
                await asyncio.sleep(0.1)

        def state(k: int) -> None:
            me.link.put(me.keys.topic("benchctl", "state"),
                        encode_body(ControllerState(stamp=0.1 * k, x=float(k), y=0.0, yaw=0.0, v=10.0, curvature=0.0)))

        # the first gate is crossed back and forth until it fires: the manager cycles on the newest state only, so a
        # state(0) overtaken by state(1) before its cycle (or before the navigator's transform came) crosses nothing.
        # Each state gets its own wait, so the manager takes it; a gate fires once. The first gate is not timed.
        for attempt in range(20):
            me.link.put(me.keys.topic("benchnav", "world_from_local"), encode_body(WorldFromLocal(stamp=0.0, x=0.0, y=0.0, yaw=0.0)))
            state(attempt % 2)
            try:
                inc = await me.receive(timeout=0.5)
            except LinkTimeout:
                continue
            if isinstance(inc.message, TriggerMessage) and inc.message.annotation_id == "g0000":
                break
            raise BenchError(f"expected the trigger of gate 0, got {inc.message!r}")
        else:
            raise BenchError("the map manager never fired the first gate (20 states across it, 0.5 s apart)")
        from_manager: list[float] = []
        from_state: list[float] = []
        for k in range(2, n + 1):
            t_pub = time.time()
            state(k)
            inc = await me.receive(timeout=5.0)
            t_arr = time.time()
            msg = inc.message
            if not isinstance(msg, TriggerMessage) or msg.annotation_id != f"g{k - 1:04d}":
                raise BenchError(f"expected the trigger of gate {k - 1}, got {msg!r}")
            from_manager.append((t_arr - msg.crossed_wall) * 1e3)
            from_state.append((t_arr - t_pub) * 1e3)
    m50, m99 = percentiles(from_manager, (50, 99))
    s50, _ = percentiles(from_state, (50, 99))
    return {"trigger_latency_p50_ms": m50, "trigger_latency_p99_ms": m99, "trigger_latency_from_state_p50_ms": s50,
            "trigger_samples": n - 1}


def measure_trigger_latency(net: NetworkConfig, samples: int) -> dict:
    """Return the map manager's trigger latency figures [ms] (the crossing cycle → arrival at the destination, wall).

    A map manager process (`python -m eddie.map_manager`, following fake `benchctl` / `benchnav`)
    loads a row of gates 1 m apart; this process publishes controller states 1 m apart, each crossing
    one gate, and waits for that gate's `TriggerMessage` in its inbox before the next. `trigger_latency_p50_ms`
    runs from `crossed_wall` (the crossing state's arrival at the manager) to the arrival at the
    destination; `trigger_latency_from_state_p50_ms` from the state's publication (the hop to the manager included).
    """
    import tempfile

    from eddie.annotated_map import Annotation, Location, save_annotations
    from eddie.messages.map_manager import SetSpeed, encode_trigger_data

    n = max(2, min(samples, TRIGGER_SAMPLES_MAX))  # gate 0 is crossed until it fires, untimed
    gates = [Annotation(id=f"g{k:04d}", type="set_speed", destination="bench_dest", trigger="cross",
                        location=Location.line([(k + 0.5, -2.0), (k + 0.5, 2.0)]), data=encode_trigger_data(SetSpeed(speed=1.0)))
             for k in range(n)]
    with tempfile.TemporaryDirectory(prefix="bench-eddie-") as tmp:
        path = Path(tmp) / "gates.geojson"
        save_annotations(path, gates)
        mm = _spawn(["-m", "eddie.map_manager", "--annotated-map", str(path), "--controller", "benchctl",
                     "--navigator", "benchnav", "--ns", net.namespace, "--connect", net.connect[0]], "SIDEWALK-READY map_manager")
        try:
            return asyncio.run(_trigger_bench(net, path, n))
        finally:
            _stop(mm)


async def _bench(ns: str, ep: str, samples: int) -> dict:
    net = NetworkConfig(namespace=ns, mode="client", connect=(ep,))
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
                raise BenchError("the floor process did not answer")
            pos_us.append((t1 - t0) * 1e6)
            floor_us.append((t2 - t1) * 1e6)
    p50, p99 = percentiles(pos_us, (50, 99))
    f50, f99 = percentiles(floor_us, (50, 99))
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
        out.update(measure_trigger_latency(NetworkConfig(namespace=ns, mode="client", connect=(ep,)), samples))
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
    from sidewalk.json_out import dumps

    print(dumps(run(args.samples), sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
