"""A small Sidewalk system for the modules' integration tests: a real blackboard node (own process),
the CAPTAIN and MAP NAVIGATOR (real modules, each with its own Zenoh sessions), a sim clock the
test advances, and a scripted PILOT answering route segments (the PILOT is built elsewhere)."""

from __future__ import annotations

import asyncio
import io
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import AsyncIterator, Callable

import msgpack

from blackboard import AttrPredicate, BlackboardClient, NetworkConfig, Spec
from blackboard.testing import NodeProcess, start_node
from codger.captain import CaptainOptions
from codger.captain.__main__ import captain_main
from codger.map_navigator import ServiceOptions
from codger.map_navigator.__main__ import navigator_main, start_position
from sidewalk.mission_client import MissionClient
from modules.map_navigator import NavigatorOptions, load_map
from codger.blackboard_part import BlackboardPart
from runtime import ModuleKeys, Link, run_module_async
from modules.vocabulary import MissionStatus, RouteSegmentDescription, SegmentResult

__all__ = ["System", "system", "ScriptedPilot", "Answer"]

#: How the scripted PILOT answers a segment: (success, reason, end_xy) or None to leave it pending.
Answer = Callable[[RouteSegmentDescription], "tuple[bool, str, tuple[float, float] | None] | None"]


def _always_ok(seg: RouteSegmentDescription) -> tuple[bool, str, tuple[float, float] | None]:
    return True, "", seg.exit.point


@dataclass
class ScriptedPilot:
    """Answer every new active route segment with `answer(seg)` (None: leave it unanswered)."""

    bb: BlackboardClient
    answer: Answer = _always_ok
    seen: list[RouteSegmentDescription] = field(default_factory=list)
    cancelled: list[str] = field(default_factory=list)
    new_segment: asyncio.Event = field(default_factory=asyncio.Event)

    async def run(self) -> None:
        async with self.bb.monitor(Spec(type="route_segment")) as mon:
            async for ev in mon:
                seg: RouteSegmentDescription = ev.token.attrs
                if seg.state == "cancelled":
                    self.cancelled.append(seg.segment_id)
                    self.new_segment.set()
                    continue
                if ev.kind != "new":
                    continue
                self.seen.append(seg)
                self.new_segment.set()
                ans = self.answer(seg)
                if ans is not None:
                    await self.reply(seg, *ans)

    async def reply(self, seg: RouteSegmentDescription, ok: bool, reason: str = "", end: tuple[float, float] | None = None) -> None:
        await self.bb.post(SegmentResult(segment_id=seg.segment_id, plan_id=seg.plan_id, segment_index=seg.segment_index,
                                         success=ok, reason=reason, end_xy=end, distance_m=seg.length_m), stamp=0.0)

    async def wait_segments(self, n: int, timeout: float = 20.0) -> None:
        async def until() -> None:
            while len(self.seen) < n:
                self.new_segment.clear()
                await self.new_segment.wait()
        await asyncio.wait_for(until(), timeout)


@dataclass
class System:
    """Handles on a running test system."""

    node: NodeProcess
    net: NetworkConfig
    keys: ModuleKeys
    link: Link
    bb: BlackboardClient
    missions: MissionClient
    pilot: ScriptedPilot
    tasks: dict[str, asyncio.Task]

    def tick(self, t: float) -> None:
        """Publish sim time `t` [s] on the sim clock key."""
        self.link.put(self.keys.sim_clock, msgpack.packb({"t": t}))

    async def wait_status(self, mission_id: str, pred: Callable[[MissionStatus], bool], timeout: float = 30.0) -> MissionStatus:
        """Wait until the mission's `mission_status` token satisfies `pred`; return it."""
        spec = Spec(type="mission_status", where=(AttrPredicate(path="mission_id", op="==", value=mission_id),))

        async def run() -> MissionStatus:
            async with self.bb.monitor(spec) as mon:
                for tok in await self.bb.retrieve(spec):
                    if pred(tok.attrs):
                        return tok.attrs
                async for ev in mon:
                    if pred(ev.token.attrs):
                        return ev.token.attrs
            raise AssertionError("monitor ended")

        return await asyncio.wait_for(run(), timeout)

    async def start_navigator(self, *, vehicle: str = "terregator", pilot_grace: float = 15.0) -> None:
        m = load_map("campus")
        main = navigator_main(m, start_position(m, None), NavigatorOptions(vehicle=vehicle), ServiceOptions(pilot_grace_s=pilot_grace))
        self.tasks["map_navigator"] = asyncio.create_task(run_module_async(
            "map_navigator", main, self.net, parts=(BlackboardPart(),), install_signals=False, stdout=io.StringIO(), heartbeat_period=0.2))

    async def stop_module(self, name: str) -> None:
        task = self.tasks.pop(name)
        task.cancel()
        try:
            await task
        except asyncio.CancelledError:
            pass


async def _wait_alive(link: Link, keys: ModuleKeys, names: set[str], timeout: float = 30.0) -> None:
    seen: set[str] = set()
    changed = asyncio.Event()

    def on(key: str, alive: bool) -> None:
        if alive:
            seen.add(key.rsplit("/", 1)[-1])
            changed.set()

    link.watch_alive(keys.alive_all, on)

    async def until() -> None:
        while not names <= seen:
            changed.clear()
            await changed.wait()

    await asyncio.wait_for(until(), timeout)


@asynccontextmanager
async def system(ns: str, *, answer: Answer = _always_ok, navigator: bool = True, captain: CaptainOptions = CaptainOptions(),
                 pilot_grace: float = 15.0) -> AsyncIterator[System]:
    """Start node, CAPTAIN, MAP NAVIGATOR (unless told not to), the test's link and the scripted PILOT."""
    node = await asyncio.to_thread(start_node, namespace=ns, types=("modules.vocabulary",))
    net = node.client_net()
    keys = ModuleKeys(ns)
    link = Link.open(net)
    bb = await BlackboardClient.connect(net, source="test")
    pilot = ScriptedPilot(bb, answer)
    sysm = System(node, net, keys, link, bb, MissionClient(link, keys), pilot, {})
    try:
        sysm.tasks["pilot"] = asyncio.create_task(pilot.run())
        sysm.tasks["captain"] = asyncio.create_task(run_module_async(
            "captain", captain_main([], captain), net, parts=(BlackboardPart(),), install_signals=False, stdout=io.StringIO(), heartbeat_period=0.2))
        want = {"captain"}
        if navigator:
            await sysm.start_navigator(pilot_grace=pilot_grace)
            want.add("map_navigator")
        await _wait_alive(link, keys, want)
        if navigator:
            # alive comes before the map is posted; the CAPTAIN checks destinations against it
            await bb.wait(Spec(type="map_places"), timeout=30.0)
        sysm.tick(0.0)
        yield sysm
    finally:
        for name in list(sysm.tasks):
            await sysm.stop_module(name)
        await bb.close()
        link.close()
        await asyncio.to_thread(node.stop)
