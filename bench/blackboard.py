"""Blackboard benchmark: node and client in separate processes on loopback, beside the raw-Zenoh floor.

Four processes, as a system deploys them (`wire.flags`): the router (`sidewalk up router`), and as
its clients the blackboard node (`python -m blackboard`), a floor process (`python -m
bench.blackboard floor`) with a raw queryable that answers at once and a raw relay that re-puts
every sample, and this client. Every message travels through the router, the floor's as the node's
(before session 25 the node and the floor listened and the client was their peer: one hop less).
Latencies are measured with the same asyncio client harness for the node and for the floor
(reply/sample callback → `call_soon_threadsafe` → future), and the two are sampled interleaved so
machine noise hits both alike. Figures in microseconds.

Keys: notify_p50_us/p99 vs zenoh_relay_p50_us/p99 (post→monitor event through the node vs a raw
put relayed by a third process); post_ack_p50_us/p99 against both floors, sampled interleaved with it:
zenoh_get_p50_us (a raw get: `post_vs_zenoh_get`) and post_ack_zenoh_relay_p50_us (a put answered by
a put, as a post and its acknowledgement travel: `post_ack_vs_zenoh_relay`, the matching floor);
retrieve_100k_p50_us/p99 (within-polygon spec returning about 50 of `tokens`), post_throughput_per_s
(pipelined, acknowledged), transform_10k_points_us p50/p99 (vehicle@t → world as the modules do it:
`BlackboardClient.transform`, each lookup asked of the node; beside it transform_10k_points_cache_us,
a client keeping a frame cache, `blackboard.frame_cache`, which no module uses).
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import math
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
from pydantic import BaseModel, ConfigDict

from bench.errors import BenchError
from blackboard import (
    BlackboardClient,
    NetworkConfig,
    Point,
    Polygon,
    Pose2D,
    Spec,
    Within,
    token_type,
)
from blackboard.testing import start_node
from bench.eddie import _spawn, _stop
from wire.keys import Keys
from wire.ports import free_port
from wire.session import Query, open_session
from wire.summary import percentiles

__all__ = ["run", "BenchItem", "BenchNote"]


@token_type("bench_item")
class BenchItem(BaseModel):
    """A token for the retrieve benchmark."""

    model_config = ConfigDict(frozen=True)
    seq: int
    value: float = 0.0


@token_type("bench_note")
class BenchNote(BaseModel):
    """A token for the latency benchmarks."""

    model_config = ConfigDict(frozen=True)
    seq: int


_WORLD = 1000.0  # side of the square the 100k points are spread over [m]


# ---------------------------------------------------------------------- floor process
def _floor_main(endpoint: str, ns: str) -> None:
    """Serve the raw floors through wire's thinnest path (raw Zenoh-thread callbacks, no asyncio), a client of the router at `endpoint`."""
    keys = Keys(ns)
    s = open_session(NetworkConfig(namespace=ns, mode="client", connect=(endpoint,)))
    s.wait_connected(20.0, name="floor")
    pub = s.publisher(keys.bench("floor-out"))

    def on_query(q: Query) -> None:
        q.reply(q.payload)
        q.finish()

    s.queryable(keys.bench("floor-echo"), on_query)
    s.subscribe_payload(keys.bench("floor-in"), lambda _key, payload: pub.put(payload))
    s.liveliness_token(keys.alive("floor"))
    stop = False

    def on_sig(*_: object) -> None:
        nonlocal stop
        stop = True

    signal.signal(signal.SIGTERM, on_sig)
    signal.signal(signal.SIGINT, on_sig)
    print("floor ready", flush=True)
    while not stop:
        # sigtimedwait may consume the signal itself (the handler then never runs): a return ends the wait
        if hasattr(signal, "sigtimedwait"):
            if signal.sigtimedwait([signal.SIGTERM, signal.SIGINT], 0.5) is not None:
                stop = True
        else:
            time.sleep(0.5)
    s.close()


def _start_floor(ns: str, ep: str) -> subprocess.Popen:
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    p = subprocess.Popen([sys.executable, "-m", "bench.blackboard", "floor", "--endpoint", ep, "--ns", ns],
                         stdout=subprocess.PIPE, text=True, env=env)
    assert p.stdout is not None
    r, _, _ = select.select([p.stdout], [], [], 60)  # a loaded machine starts Python slowly
    line = p.stdout.readline() if r else ""
    if not line.startswith("floor ready"):
        p.kill()
        raise BenchError(f"floor process failed to start: {line!r}")
    return p


# ---------------------------------------------------------------------- measurements
class _Floor:
    """Raw zenoh get/put through the same session and asyncio harness the client uses."""

    def __init__(self, bb: BlackboardClient, ns: str) -> None:
        self.s = bb._session
        self.loop = asyncio.get_running_loop()
        keys = Keys(ns)
        self.echo = keys.bench("floor-echo")
        self.inp = keys.bench("floor-in")
        self.waiter: asyncio.Future | None = None
        self.s.subscribe(keys.bench("floor-out"), lambda smp: self.loop.call_soon_threadsafe(self._got, smp))

    def _got(self, smp: object) -> None:
        if self.waiter is not None and not self.waiter.done():
            self.waiter.set_result(smp)

    async def get(self, payload: bytes) -> None:
        fut = self.loop.create_future()
        self.s.get(self.echo, payload, as_json=False, timeout=10,
                   on_reply=lambda r: self.loop.call_soon_threadsafe(lambda: fut.done() or fut.set_result(r)),
                   on_done=lambda: self.loop.call_soon_threadsafe(lambda: fut.done() or fut.set_exception(TimeoutError("floor get"))))
        await fut

    async def relay(self, payload: bytes) -> None:
        self.waiter = self.loop.create_future()
        self.s.put(self.inp, payload)
        await asyncio.wait_for(self.waiter, 10)


async def _bench(net: NetworkConfig, ns: str, tokens: int, samples: int) -> dict:
    out: dict = {}
    async with BlackboardClient(net, source="bench", timeout=60) as bb:
        floor = _Floor(bb, ns)
        note_payload = {"op": "post", "type": "bench_note", "attrs": {"seq": 0}, "frame": "world", "stamp": 0.0,
                        "source": "bench", "geometry": {"kind": "point", "x": 1.0, "y": 2.0}}
        from blackboard.codec import encode

        floor_payload = encode([note_payload])
        # warm up both paths
        for i in range(200):
            await bb.post(BenchNote(seq=i), geometry=Point(x=1, y=2), stamp=float(i))
            await floor.get(floor_payload)
            await floor.relay(floor_payload)

        gc.collect()
        gc.freeze()
        # --- post ack vs a raw get and a raw relay (interleaved): a post is a put answered by a put
        pa, zg, zp = [], [], []
        pc = time.perf_counter
        for i in range(samples):
            t0 = pc()
            await bb.post(BenchNote(seq=i), geometry=Point(x=1, y=2), stamp=float(i))
            t1 = pc()
            await floor.get(floor_payload)
            t2 = pc()
            await floor.relay(floor_payload)
            t3 = pc()
            pa.append(t1 - t0)
            zg.append(t2 - t1)
            zp.append(t3 - t2)
        out["post_ack_p50_us"], out["post_ack_p99_us"] = percentiles(pa, (50, 99), scale=1e6)
        out["zenoh_get_p50_us"], out["zenoh_get_p99_us"] = percentiles(zg, (50, 99), scale=1e6)
        out["post_ack_zenoh_relay_p50_us"], out["post_ack_zenoh_relay_p99_us"] = percentiles(zp, (50, 99), scale=1e6)
        out["post_vs_zenoh_get"] = out["post_ack_p50_us"] / out["zenoh_get_p50_us"]
        out["post_ack_vs_zenoh_relay"] = out["post_ack_p50_us"] / out["post_ack_zenoh_relay_p50_us"]

        # --- notify vs relay (interleaved)
        nt, zr = [], []
        async with bb.monitor(Spec(type="bench_note")) as mon:
            for i in range(50):
                await bb.post(BenchNote(seq=i), stamp=0.0)
                await mon.next(10)
            for i in range(samples):
                t0 = pc()
                ack = asyncio.ensure_future(bb.post(BenchNote(seq=i), geometry=Point(x=1, y=2), stamp=float(i)))
                await anext(mon)
                t1 = pc()
                await ack
                t2 = pc()
                await floor.relay(floor_payload)
                t3 = pc()
                nt.append(t1 - t0)
                zr.append(t3 - t2)
        out["notify_p50_us"], out["notify_p99_us"] = percentiles(nt, (50, 99), scale=1e6)
        out["zenoh_relay_p50_us"], out["zenoh_relay_p99_us"] = percentiles(zr, (50, 99), scale=1e6)
        out["notify_vs_zenoh_relay"] = out["notify_p50_us"] / out["zenoh_relay_p50_us"]

        # --- throughput: pipelined, acknowledged posts (the client coalesces them into messages of at most
        # blackboard.client.MAX_WRITES_PER_MESSAGE)
        n_tp = max(20_000, samples * 10)
        window = 1000
        in_flight = 4
        item = BenchItem(seq=0)
        sem = asyncio.Semaphore(in_flight)

        async def chunk(base: int) -> None:
            async with sem:
                await asyncio.gather(*[bb.post(item, geometry=Point(x=float(j % 100), y=-10.0 - (j // 100) % 100), stamp=float(j))
                                       for j in range(base, base + window)])

        t0 = pc()
        await asyncio.gather(*[chunk(b) for b in range(0, n_tp, window)])
        out["post_throughput_per_s"] = n_tp / (pc() - t0)
        out["post_throughput_posts"] = n_tp

        # --- bulk load for retrieve: raw batch ops, 5000 per message
        rng = np.random.default_rng(12345)
        xy = rng.uniform(0.0, _WORLD, size=(tokens, 2))
        t0 = pc()
        batch = 5000
        pending = []
        for b in range(0, tokens, batch):
            ops = [{"op": "post", "type": "bench_item", "attrs": {"seq": int(k), "value": float(k)}, "frame": "world",
                    "stamp": float(k), "source": "bench", "geometry": {"kind": "point", "x": float(xy[k, 0]), "y": float(xy[k, 1])}}
                   for k in range(b, min(b + batch, tokens))]
            pending.append(bb._query(bb.keys.batch, encode(ops)))
            if len(pending) >= 4:
                await pending.pop(0)
        for p in pending:
            await p
        out["bulk_load_tokens_per_s"] = tokens / (pc() - t0)

        # --- retrieve ~50 of `tokens` by a within-polygon spec (random hexagon, random place)
        area = 50.0 * _WORLD * _WORLD / tokens  # [m²] expected to hold 50 tokens
        radius = math.sqrt(area / (1.5 * math.sqrt(3)))  # regular hexagon of that area
        specs = []
        for _ in range(samples):
            cx, cy = rng.uniform(radius, _WORLD - radius, size=2)
            pts = [(cx + radius * math.cos(a), cy + radius * math.sin(a)) for a in np.arange(6) * math.pi / 3]
            specs.append(Spec(type="bench_item", geometry=Within(Polygon(points=pts), frame="world")))
        for s in specs[:50]:
            await bb.retrieve(s)
        rt, counts = [], []
        for i, s in enumerate(specs):
            t0 = pc()
            got = await bb.retrieve(s)
            t1 = pc()
            rt.append(t1 - t0)
            counts.append(len(got))
        out["retrieve_100k_p50_us"], out["retrieve_100k_p99_us"] = percentiles(rt, (50, 99), scale=1e6)
        out["retrieve_tokens_in_store"] = tokens
        out["retrieve_mean_matches"] = float(np.mean(counts))
        out["retrieve_vs_zenoh_get"] = out["retrieve_100k_p50_us"] / out["zenoh_get_p50_us"]

        # --- transform 10k points vehicle@t → world (lookup on the node + vectorised numpy)
        await bb.post_pose(parent="world", child="local", pose=Pose2D(x=10.0, y=20.0, yaw=0.3), stamp=0.0, hold=None)
        await asyncio.gather(*[bb.post_pose(parent="local", child="vehicle", pose=Pose2D(x=0.01 * t, y=0.0, yaw=0.001 * t), stamp=0.01 * t)
                               for t in range(1000)])
        pts = rng.normal(0.0, 10.0, size=(10_000, 2))

        async def transforms(client: BlackboardClient) -> tuple[list[float], np.ndarray]:
            tt = []
            for i in range(max(samples // 2, 100)):
                stamp = 0.5 + 0.01 * (i % 800) + 0.005
                t0 = pc()
                res = await client.transform(pts, src_frame="vehicle", src_stamp=stamp, dst_frame="world")
                tt.append(pc() - t0)
            return tt, res

        # the modules' path (the PILOT, PERCEPTION): each lookup asked of the node
        tt, res = await transforms(bb)
        assert res.shape == (10_000, 2)
        out["transform_10k_points_us"], out["transform_10k_points_p99_us"] = percentiles(tt, (50, 99), scale=1e6)
        # the same with the client's frame cache (blackboard.frame_cache; the monitor's): the node's tree kept here
        async with BlackboardClient(net, source="bench-frames", timeout=60, frame_cache=True) as cached:
            tt, got = await transforms(cached)
            np.testing.assert_array_equal(got, res)  # the node's answer, to the bit
            fc = cached.frame_cache.stats
            out["transform_cache_hits"], out["transform_cache_misses"] = fc.hits, fc.misses
        out["transform_10k_points_cache_us"], out["transform_10k_points_cache_p99_us"] = percentiles(tt, (50, 99), scale=1e6)

        st = await bb.stats()
        out.update({f"node_{k}": v for k, v in st.model_dump().items()})
        gc.unfreeze()
    out["samples"] = samples
    out["cpus"] = os.cpu_count()
    out["loadavg_1m"] = os.getloadavg()[0]
    return out


def run(tokens: int = 100_000, samples: int = 2000, dispatch: str = "inline") -> dict:
    """Start a node and a floor process, measure, stop them; return the figures (see module docstring)."""
    if tokens < 1 or samples < 10:
        raise ValueError("tokens must be ≥ 1 and samples ≥ 10")
    ns = f"bench{os.getpid()}"
    tmp = tempfile.mkdtemp(prefix="bb-bench-")
    ep = f"tcp/127.0.0.1:{free_port()}"
    router = _spawn(["-m", "sidewalk", "up", "router", "--ns", ns, "--listen", ep], "router ready")
    node = floor = None
    try:
        node = start_node(namespace=ns, types=("bench.blackboard",), db=os.path.join(tmp, "bench.sqlite"), dispatch=dispatch,
                          router=ep, timeout=60.0)
        floor = _start_floor(ns, ep)
        out = asyncio.run(_bench(node.client_net(), ns, tokens, samples))
        out["node_dispatch"] = dispatch
        out["node_db"] = "sqlite file, WAL, synchronous=NORMAL"
        return out
    finally:
        if floor is not None:
            floor.send_signal(signal.SIGTERM)
            try:
                floor.wait(10)
            except subprocess.TimeoutExpired:
                floor.kill()
            if floor.stdout:
                floor.stdout.close()
        if node is not None:
            node.stop()
        _stop(router)
        shutil.rmtree(tmp, ignore_errors=True)


def _main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.blackboard")
    sub = ap.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("floor", help="run the raw-Zenoh floor process (echo queryable + relay)")
    f.add_argument("--endpoint", required=True)
    f.add_argument("--ns", required=True)
    r = sub.add_parser("run", help="run the benchmark and print JSON")
    r.add_argument("--tokens", type=int, default=100_000)
    r.add_argument("--samples", type=int, default=2000)
    r.add_argument("--dispatch", default="inline", choices=["inline", "loop"])
    a = ap.parse_args(argv)
    if a.cmd == "floor":
        _floor_main(a.endpoint, a.ns)
    else:
        from sidewalk.json_out import dumps

        print(dumps(run(a.tokens, a.samples, a.dispatch), sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(_main())
