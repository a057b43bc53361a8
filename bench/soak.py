"""Soak benchmark: a real blackboard node (own process, SQLite on disk) held at a post rate for minutes.

Three processes: the node (`python -m blackboard`), a watcher (`python -m bench.soak watch`) holding
`monitors` monitors — monitor i matches the posts of lane i, and post j goes to lane j mod
`monitors`, so every post is one notification — and this poster, which posts `rate` tokens a second
(pipelined, each acknowledged) and deletes the oldest beyond `keep` so the store stays bounded (a
growing resident memory is then a leak, not data). Each post carries its wall send time [s]; the
watcher measures post → notification latency on arrival. At the end the watcher waits for
stragglers and reports every sequence number it never saw as lost.

Keys: posts, held_target (posts ≥ 98 % of rate × time), issued_rate_per_s (the schedule kept, or
what the node's acknowledgements allowed with `MAX_IN_FLIGHT` posts waiting), acked_rate_per_s (posts over the time until
the last acknowledgement), ack_backlog_s (how long acknowledgements trailed the schedule), notifications, lost, duplicates, per_minute (p50/p99 latency [ms]
and posts per minute), latency_p99_ms (whole run), node_rss_mb_start/end/max, post_errors.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections import deque

import numpy as np
import psutil
from pydantic import BaseModel, ConfigDict

from bench.errors import BenchError
from blackboard import AttrPredicate, BlackboardClient, NetworkConfig, Spec, token_type
from blackboard.testing import start_node
from wire.summary import percentiles

__all__ = ["run", "SoakItem"]

#: How long [s] wall the watcher waits for stragglers after the last post.
DRAIN_S = 15.0
#: Posts are issued in ticks of this length [s] wall.
TICK_S = 0.01
#: Posts awaiting their acknowledgement at most (beyond, the schedule waits for the node).
MAX_IN_FLIGHT = 2000


@token_type("soak_item")
class SoakItem(BaseModel):
    """A soak token: sequence number, lane (which monitor sees it), wall send time [s]."""

    model_config = ConfigDict(frozen=True)
    seq: int
    lane: int
    sent: float


async def _watch(net: NetworkConfig, monitors: int) -> None:
    """Hold `monitors` monitors; print "ready", read "end N" on stdin, drain, print the result as JSON."""
    bb = await BlackboardClient.connect(net, source="soak-watcher")
    seen: dict[int, float] = {}
    dups = 0
    t0 = time.time()
    got_all = asyncio.Event()
    expected: list[int] = []
    registered: list[int] = []
    all_registered = asyncio.Event()

    async def follow(lane: int) -> None:
        nonlocal dups
        async with bb.monitor(Spec(type="soak_item", where=(AttrPredicate(path="lane", op="==", value=lane),))) as mon:
            registered.append(lane)  # entering the block waited for the node's acknowledgement of the monitor
            if len(registered) == monitors:
                all_registered.set()
            async for ev in mon:
                if ev.kind != "new":
                    continue
                item = ev.token.attrs
                if item.seq in seen:
                    dups += 1
                    continue
                seen[item.seq] = time.time() - item.sent
                if expected and len(seen) >= expected[0]:
                    got_all.set()

    tasks = [asyncio.create_task(follow(i)) for i in range(monitors)]
    waiter = asyncio.ensure_future(all_registered.wait())
    await asyncio.wait([waiter, *tasks], return_when=asyncio.FIRST_COMPLETED)  # a lane that failed ends the wait too
    for t in tasks:
        if t.done() and t.exception() is not None:
            raise t.exception()  # type: ignore[misc]
    print("ready", flush=True)
    line = await asyncio.to_thread(sys.stdin.readline)
    total = int(line.split()[1]) if line.startswith("end") else 0
    expected.append(total)
    if len(seen) < total:
        try:
            await asyncio.wait_for(got_all.wait(), DRAIN_S)
        except asyncio.TimeoutError:
            pass
    for t in tasks:
        t.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)
    await bb.close()
    print(json.dumps({"received": len(seen), "duplicates": dups, "t0": t0,
                      "latency": {str(k): v for k, v in seen.items()}}), flush=True)


async def _post(net: NetworkConfig, rate: float, seconds: float, monitors: int, keep: int, node_pid: int) -> dict:
    """Post `rate` items a second for `seconds` [s], at most `MAX_IN_FLIGHT` unacknowledged; return what the poster measured.

    When the node falls behind, the schedule waits for acknowledgements instead of piling up
    requests: the issued rate then says what the node held.
    """
    bb = await BlackboardClient.connect(net, source="soak-poster")
    node = psutil.Process(node_pid)
    rss = [node.memory_info().rss]
    sent_at: list[float] = []
    errors = 0
    live: deque[str] = deque()
    in_flight: set[asyncio.Task] = set()
    sem = asyncio.Semaphore(MAX_IN_FLIGHT)

    async def one(seq: int, sent: float) -> None:
        nonlocal errors
        try:
            tok = await bb.post(SoakItem(seq=seq, lane=seq % monitors, sent=sent), stamp=float(seq))
            live.append(tok.id)
            while keep and len(live) > keep:
                await bb.delete(live.popleft())
        except Exception:  # noqa: BLE001 - every failure counts the same: a post not acknowledged
            errors += 1
        finally:
            sem.release()

    loop = asyncio.get_running_loop()
    t0 = loop.time()
    seq = 0
    next_rss = t0 + 10.0
    try:
        while (now := loop.time()) - t0 < seconds:
            due = int((now - t0) * rate) + 1
            while seq < due and loop.time() - t0 < seconds:
                await sem.acquire()  # the node's pace, once MAX_IN_FLIGHT posts wait for it
                sent = time.time()
                task = asyncio.create_task(one(seq, sent))
                in_flight.add(task)
                task.add_done_callback(in_flight.discard)
                sent_at.append(sent)
                seq += 1
            if now >= next_rss:
                rss.append(node.memory_info().rss)
                next_rss += 10.0
            await asyncio.sleep(TICK_S)  # pacing: the post schedule is the clock
        issued = loop.time() - t0
        if in_flight:
            await asyncio.wait(set(in_flight), timeout=60)
        elapsed = loop.time() - t0
        unacked = len(in_flight)
        for t in list(in_flight):
            t.cancel()
        rss.append(node.memory_info().rss)
    finally:
        await asyncio.wait_for(bb.close(), 30)
    return {"posts": seq, "issued_s": issued, "elapsed_s": elapsed, "errors": errors + unacked, "sent_at": sent_at, "rss": rss}


def run(*, minutes: float = 10.0, rate: float = 1000.0, monitors: int = 20, keep: int = 10_000) -> dict:
    """Run the soak; return the figures (see the module docstring)."""
    tmp = tempfile.mkdtemp(prefix="sidewalk-soak-")
    try:
        with start_node(namespace="soak", db=os.path.join(tmp, "soak.db"), types=("bench.soak",)) as node:
            net = node.client_net()
            env = {**os.environ, "PYTHONPATH": os.path.dirname(os.path.dirname(os.path.abspath(__file__)))}
            watcher = subprocess.Popen(
                [sys.executable, "-m", "bench.soak", "watch", "--connect", net.connect[0], "--ns", net.namespace,
                 "--monitors", str(monitors)],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
            try:
                assert watcher.stdout is not None and watcher.stdin is not None
                if watcher.stdout.readline().strip() != "ready":
                    raise BenchError("the soak watcher did not come up")
                posted = asyncio.run(_post(net, rate, minutes * 60.0, monitors, keep, node.proc.pid))
                watcher.stdin.write(f"end {posted['posts']}\n")
                watcher.stdin.flush()
                result = json.loads(watcher.stdout.readline())
            finally:
                watcher.kill()
                watcher.wait(10)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    lat = {int(k): v for k, v in result["latency"].items()}
    t_first = posted["sent_at"][0] if posted["sent_at"] else 0.0
    per_minute: list[dict] = []
    n_min = max(1, int(np.ceil(minutes)))
    buckets: list[list[float]] = [[] for _ in range(n_min)]
    counts = [0] * n_min
    for seq, sent in enumerate(posted["sent_at"]):
        m = min(n_min - 1, int((sent - t_first) // 60.0))
        counts[m] += 1
        if seq in lat:
            buckets[m].append(lat[seq])
    for m in range(n_min):
        p50, p99 = percentiles(buckets[m], (50, 99), scale=1e3, digits=3, empty=math.nan)
        per_minute.append({"minute": m + 1, "posts": counts[m], "p50_ms": p50, "p99_ms": p99})
    all_p50, all_p99 = percentiles(list(lat.values()), (50, 99), scale=1e3, digits=3, empty=math.nan)
    mb = 1024 * 1024
    return {
        "minutes": minutes, "rate_target_per_s": rate, "monitors": monitors, "keep_tokens": keep,
        "posts": posted["posts"], "held_target": posted["posts"] >= 0.98 * rate * minutes * 60.0,
        "issued_rate_per_s": round(posted["posts"] / posted["issued_s"], 1),
        # every post acknowledged by then: what the node sustained, backlog included
        "acked_rate_per_s": round(posted["posts"] / posted["elapsed_s"], 1),
        "ack_backlog_s": round(posted["elapsed_s"] - posted["issued_s"], 2),
        "post_errors": posted["errors"], "notifications": result["received"],
        "lost": posted["posts"] - result["received"], "duplicates": result["duplicates"],
        "latency_p50_ms": all_p50, "latency_p99_ms": all_p99, "per_minute": per_minute,
        "node_rss_mb_start": round(posted["rss"][0] / mb, 1), "node_rss_mb_end": round(posted["rss"][-1] / mb, 1),
        "node_rss_mb_max": round(max(posted["rss"]) / mb, 1),
    }


def main(argv: list[str] | None = None) -> None:
    """`python -m bench.soak watch …`: the watcher process."""
    p = argparse.ArgumentParser(prog="python -m bench.soak")
    p.add_argument("role", choices=["watch"])
    p.add_argument("--connect", required=True)
    p.add_argument("--ns", required=True)
    p.add_argument("--monitors", type=int, default=20)
    a = p.parse_args(argv)
    asyncio.run(_watch(NetworkConfig(namespace=a.ns, connect=(a.connect,)), a.monitors))


if __name__ == "__main__":
    main()
