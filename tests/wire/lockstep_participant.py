"""A lock-step participant for the barrier tests, run as its own process.

`python -m tests.wire.lockstep_participant NAME ENDPOINT NS [--work S] [--forward NAME] [--hold]`: connects to
ENDPOINT, joins the barrier as NAME and prints `READY <participant name>`. Each sample on
`sidewalk/<ns>/test/go/NAME` starts a handler: a worker-thread job of S seconds wall (what the barrier
must wait for; with --hold, first holding the loop itself until a sample on `test/release/NAME`), then a put on `test/go/<forward>` when forwarding, else on `test/done/NAME` (or `test/done/<the sample's payload>`
when it is not `x`).
"""

from __future__ import annotations

import argparse
import asyncio
import threading
import time

from wire.aio import Link
from wire.lockstep import Participant, participant_name
from wire.network import NetworkConfig


async def main(args: argparse.Namespace) -> None:
    net = NetworkConfig(namespace=args.ns, connect=(args.endpoint,))
    link = Link.open(net)
    base = f"sidewalk/{args.ns}/test"
    tasks: set[asyncio.Task] = set()

    release = threading.Event()  # set on a Zenoh thread by `test/release/NAME`

    async def handle(reply: str) -> None:
        if args.hold:  # a synchronous computation that holds the loop itself, until the test releases it
            release.wait(60.0)
        await asyncio.to_thread(time.sleep, args.work)
        link.put(f"{base}/go/{args.forward}" if args.forward else f"{base}/done/{reply or args.name}", b"x")

    def on_go(_key: str, data: bytes) -> None:
        t = asyncio.get_running_loop().create_task(handle("" if data == b"x" else data.decode()))
        tasks.add(t)
        t.add_done_callback(tasks.discard)

    try:
        await link.wait_connected(10.0)
        link.subscribe(f"{base}/go/{args.name}", on_go)
        link.session.subscribe_payload(f"{base}/release/{args.name}", lambda *_: release.set())  # on a Zenoh thread: the loop is held
        p = Participant(link.session, participant_name(args.name))
        print(f"READY {p.name}", flush=True)
        await asyncio.Event().wait()
    finally:
        link.close()


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("name")
    ap.add_argument("endpoint")
    ap.add_argument("ns")
    ap.add_argument("--work", type=float, default=0.3)
    ap.add_argument("--forward", default="")
    ap.add_argument("--hold", action="store_true")
    try:
        asyncio.run(main(ap.parse_args()))
    except KeyboardInterrupt:
        pass
