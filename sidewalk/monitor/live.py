"""`sidewalk monitor`: the NAVIGATION MONITOR as a process of a live system, serving its page.

Seed §2.3.8: an independent process, so it does not disturb the other modules. It subscribes to
the simulator (truth for evaluation only, marked so on the page), heartbeats, liveliness and
mission events, and runs the CODGER adapter (a blackboard reader) and/or the EDDIE adapter. High
rate streams are latest-value-wins; the page is sent at most 20 frames a second.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Literal

from blackboard import BlackboardClient, BlackboardError, TypeRegistry
from codger.blackboard_part import BlackboardPart
from runtime import ModuleRuntime, run_module
from sidewalk.monitor.codger import CodgerLive
from sidewalk.monitor.eddie import LATEST_STREAMS, STREAMS, EddieLive
from sidewalk.monitor.errors import PortInUseError
from sidewalk.monitor.latest import LatestSubscriber
from sidewalk.monitor.model import MonitorModel
from sidewalk.monitor.server import MonitorServer
from sidewalk.monitor.sources import SimSource
from sidewalk.recording.channels import decode_payload
from wire.keys import Keys
from wire.network import NetworkConfig

__all__ = ["serve_live", "LiveMonitor"]

log = logging.getLogger(__name__)

Arch = Literal["auto", "codger", "eddie"]


class LiveMonitor:
    """Wire a model to a live system: subscriptions, adapters, static queries (see module docstring)."""

    def __init__(self, rt: ModuleRuntime, model: MonitorModel, *, arch: Arch = "auto") -> None:
        self.rt = rt
        self.model = model
        self.arch = arch
        self.keys = Keys(rt.net.namespace)
        self.root = self.keys.root + "/"
        self.sim = SimSource(model)
        self.eddie = EddieLive(model, rt.link, rt.net.namespace)
        self._tasks: list[asyncio.Task] = []
        self.bb: BlackboardClient | None = None

    def _rel(self, key: str) -> str:
        return key[len(self.root):] if key.startswith(self.root) else key

    def _on_sample(self, key: str, payload: bytes) -> None:
        rel = self._rel(key)
        try:
            v = decode_payload(payload, False)
        except Exception:  # noqa: BLE001 - a bad payload is skipped
            return
        if not self.sim.on_sample(rel, v):
            self.eddie.interp.on_sample(rel, v)

    async def start(self) -> None:
        """Declare the subscriptions and start the adapters."""
        loop = asyncio.get_running_loop()
        link, k = self.rt.link, self.keys
        latest = LatestSubscriber(link.session, loop, self._on_sample)
        for key in (k.sim.truth, k.sim.clock, k.sim.preview):
            latest.subscribe(key)
        for key in (k.sim.events, k.heartbeat_all, k.mission.events):
            link.subscribe(key, self._on_sample)
        link.watch_alive(k.alive_all, lambda key, alive: self.sim.on_alive(self._rel(key)[len("alive/"):], alive))
        self._spawn(self._fetch_maps())
        if self.arch in ("eddie", "auto"):
            for module, stream in STREAMS:
                key = k.eddie.topic(module, stream)
                if (module, stream) in LATEST_STREAMS:
                    latest.subscribe(key)
                else:
                    link.subscribe(key, self._on_sample)
            self._spawn(self.eddie.run())
        if self.arch == "codger":
            await self._attach_blackboard()
        elif self.arch == "auto":
            self._spawn(self._attach_when_alive())

    def _spawn(self, coro) -> None:  # noqa: ANN001 - a coroutine
        self._tasks.append(asyncio.ensure_future(coro))

    async def _fetch_maps(self) -> None:
        """Ask the simulator for the map and the world until it answers (both are static)."""
        for rel, key in (("sim/map", self.keys.sim.map), ("sim/world", self.keys.sim.world)):
            while True:
                replies = await self.rt.link.get(key, timeout=5.0)
                ok = [r for r in replies if r.ok]
                if ok:
                    self.sim.on_sample(rel, decode_payload(ok[0].payload, True))
                    break
                await asyncio.sleep(1.0)  # the simulator is not up yet

    async def _attach_blackboard(self) -> None:
        # the live view converts poses several times a second: a frame cache answers them without a round trip
        self.bb = await BlackboardClient.connect(self.rt.net, source="monitor", registry=TypeRegistry(), lenient=True,
                                                 connect_timeout=30.0, frame_cache=True)
        await self.rt.plug(BlackboardPart(client=self.bb))  # the runtime closes it on the way out
        codger = CodgerLive(self.model, self.bb)
        self._spawn(codger.run())

    async def _attach_when_alive(self) -> None:
        appeared = asyncio.Event()
        self.rt.link.watch_alive(self.keys.bb.alive, lambda _k, alive: alive and appeared.set())
        await appeared.wait()
        try:
            await self._attach_blackboard()
        except BlackboardError as exc:
            log.warning("monitor: a blackboard appeared but cannot be read: %s", exc)

    async def stop(self) -> None:
        """Cancel the adapters."""
        for t in self._tasks:
            t.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)


def serve_live(net: NetworkConfig, *, host: str = "127.0.0.1", port: int = 8080, arch: Arch = "auto") -> int:
    """Run the monitor process until SIGINT/SIGTERM; return the exit code (2: the port is taken)."""
    code = {"port": 0}

    async def main(rt: ModuleRuntime) -> None:
        model = MonitorModel(arch=arch)
        model.set_meta(namespace=net.namespace, source="live")
        server = MonitorServer(model, host, port)
        try:
            await server.start()
        except PortInUseError as exc:
            print(f"monitor: error: {exc}", flush=True)
            code["port"] = 2
            return
        live = LiveMonitor(rt, model, arch=arch)
        try:
            await live.start()
            rt.ready()
            print(f"monitor: {server.url} (namespace {net.namespace})", flush=True)
            await rt.stop_event.wait()
        finally:
            await live.stop()
            await server.stop()

    rc = run_module("monitor", main, net)
    return code["port"] or rc
