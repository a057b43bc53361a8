"""`sidewalk record`: the recorder as a process of the system (liveliness, heartbeat, ready line, clean stop).

`--arch codger` waits for the blackboard node and monitors every token before it says ready;
`--arch eddie` records without a blackboard; `--arch auto` starts at once and attaches to a
blackboard node whenever one appears. SIGINT/SIGTERM finish the file (summary and indexes) and exit 0.
"""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path
from typing import Literal

from blackboard import BlackboardClient, BlackboardError, TypeRegistry
from codger.blackboard_part import BlackboardPart
from runtime import ModuleRuntime, run_module_async
from sidewalk.recording.recorder import RunRecorder
from wire.network import NetworkConfig

__all__ = ["record", "Arch"]

log = logging.getLogger(__name__)

#: Which architecture's extras to record: the CODGER blackboard, EDDIE, or whatever appears.
Arch = Literal["codger", "eddie", "auto"]


async def _bb_client(net: NetworkConfig, timeout: float) -> BlackboardClient:
    # an empty registry and lenient: token attrs stay the node's plain dicts (recorded as they are)
    return await BlackboardClient.connect(net, source="recorder", registry=TypeRegistry(), lenient=True, connect_timeout=timeout)


def record(net: NetworkConfig, path: Path, *, arch: Arch = "codger", connect_timeout: float = 30.0) -> int:
    """Record namespace `net.namespace` into `path` until SIGINT/SIGTERM; return the exit code."""
    made: list[RunRecorder] = []

    async def main(rt: ModuleRuntime) -> None:
        rec = RunRecorder(rt.link, path, net.namespace, metadata={"arch": arch})
        made.append(rec)
        watcher: asyncio.Task | None = None
        try:
            if arch == "codger":
                await rt.plug(BlackboardPart(client=await _bb_client(net, connect_timeout)))  # the runtime closes it on the way out
            await rec.start(rt.bb)
            if arch == "auto":
                appeared = asyncio.Event()
                rt.link.watch_alive(rt.keys.root + "/alive/blackboard", lambda _k, alive: alive and appeared.set())

                async def attach() -> None:
                    await appeared.wait()
                    try:
                        await rt.plug(BlackboardPart(client=await _bb_client(net, connect_timeout)))
                        await rec.attach_blackboard(rt.bb)
                    except BlackboardError as exc:
                        log.warning("recorder: blackboard appeared but cannot be monitored: %s", exc)

                watcher = asyncio.ensure_future(attach())
            rt.ready()
            print(f"recorder: recording namespace {net.namespace} to {path}", flush=True)
            await rt.stop_event.wait()
        finally:
            if watcher is not None:
                watcher.cancel()
            rec.request_stop()  # the writer thread drains what is queued; `finish` below waits for it

    code = asyncio.run(run_module_async("recorder", main, net))
    for rec in made:
        rec.finish()
        print(f"recorder: wrote {sum(rec.sink.counts.values())} messages on {len(rec.sink.counts)} channels to {path} "
              f"(writer CPU {rec.cpu_s:.2f} s, {rec.errors} errors)", flush=True)
    return code
