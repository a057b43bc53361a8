"""The map manager process: queries (envelope and the monitor's JSON), triggers fired once into a module's inbox.

The test plays the controller and the navigator on their streams (fake states on a real Zenoh link)
and the `vision` module whose inbox the triggers reach; the manager is a real process.
"""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys

from wire.network import NetworkConfig
from wire.ports import free_port

from eddie.annotated_map import Annotation, Location, save_annotations
from eddie.map_manager.map_manager import MapManager, world_of
from eddie.annotated_map import AnnotationDatabase
from eddie.messages.controller import ControllerState
from eddie.messages.map_manager import (AnnotationList, AnnotationQuery, SetSpeed, TriggerFired, TriggerMessage,
                                        encode_trigger_data, open_trigger_data)
from eddie.messages.navigator import WorldFromLocal
from eddie.toolkit import Module
from tests.eddie._net import retry
from eddie.toolkit.message import encode_body
from tests.modules._procs import spawn, stop


def _gate(aid: str, x: float, speed: float) -> Annotation:
    return Annotation(id=aid, type="set_speed", destination="vision", text=f"gate {aid}", trigger="cross",
                      location=Location.line([(x, -3.0), (x, 3.0)]), data=encode_trigger_data(SetSpeed(speed=speed)))


ANNS = [
    _gate("a", 1.0, 1.0),  # only crossed if the manager ignored world←local
    _gate("b", 5.0, 2.0),
    _gate("c", 8.0, 3.0),
    Annotation(id="road", type="route", location=Location.polygon([(0, -4), (20, -4), (20, 4), (0, 4)])),
]
W = WorldFromLocal(stamp=0.0, x=3.0, y=0.0, yaw=0.0)


def test_a_fix_between_cycles_is_a_jump_not_travel() -> None:
    mgr = MapManager(AnnotationDatabase(ANNS))
    assert mgr.cycle(0.0, 0.0, W).events == ()
    assert [e.annotation.id for e in mgr.cycle(2.5, 0.0, W).events] == ["b"]
    big = W.model_copy(update={"x": 30.0})  # a fix moves the vehicle 27 m ahead: c is skipped, not sent
    evs = mgr.cycle(2.6, 0.0, big).events
    assert [(e.annotation.id, e.kind) for e in evs] == [("c", "skipped")]
    assert world_of(big, 1.0, 2.0) == (31.0, 2.0)


async def test_triggers_reach_the_inbox_once_as_the_controller_crosses_them(tmp_path) -> None:
    ns = f"mm{os.getpid()}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    path = tmp_path / "gates.geojson"
    save_annotations(path, ANNS)
    procs: list[subprocess.Popen] = []
    try:
        async with Module("vision", NetworkConfig(namespace=ns, listen=(ep,))) as me:
            procs.append(spawn([sys.executable, "-m", "eddie.map_manager", "--annotated-map", str(path), "--ns", ns,
                                "--connect", ep], "SIDEWALK-READY map_manager"))
            ans = await retry(lambda: me.request("map_manager", "query", AnnotationQuery(type="set_speed"),
                                                  reply_type=AnnotationList))
            assert [r.id for r in ans.annotations] == ["a", "b", "c"]
            replies = await me.link.get(me.keys.service("map_manager", "query"),
                                        json.dumps({"type": None, "polygon": None}).encode(), timeout=5.0, as_json=True)
            body = json.loads(replies[0].payload)
            assert replies[0].ok and [a["id"] for a in body["annotations"]] == ["a", "b", "c", "road"]
            assert body["annotations"][3]["kind"] == "polygon" and len(body["annotations"][3]["points"]) == 4
            fired: list[TriggerFired] = []
            me.subscribe("map_manager", "triggers", TriggerFired, fired.append)
            # the query answered, so the manager's subscriptions are declared: play navigator and controller
            me.link.put(me.keys.topic("navigator", "world_from_local"), encode_body(W))
            # The manager cycles on the newest state: a burst of states before its first cycle would start
            # the travelled line at the burst's end. The start state first, then a round trip (answered
            # after the manager's loop took the state), then the drive.
            me.link.put(me.keys.topic("controller", "state"),
                        encode_body(ControllerState(stamp=0.0, x=0.0, y=0.1, yaw=0.0, v=2.5, curvature=0.0)))
            await me.request("map_manager", "query", AnnotationQuery(type="set_speed"), reply_type=AnnotationList)
            for k in range(1, 25):  # local x 0 → 6 m: world 3 → 9 m
                st = ControllerState(stamp=0.1 * k, x=0.25 * k, y=0.1, yaw=0.0, v=2.5, curvature=0.0)
                me.link.put(me.keys.topic("controller", "state"), encode_body(st))
            got = [await me.receive(timeout=15.0), await me.receive(timeout=15.0)]
            msgs = [g.message for g in got]
            assert all(isinstance(m, TriggerMessage) for m in msgs)
            assert [m.annotation_id for m in msgs] == ["b", "c"]
            assert [open_trigger_data(m).speed for m in msgs] == [2.0, 3.0]
            assert abs(msgs[0].x - 5.0) < 1e-6 and abs(msgs[0].y - 0.1) < 1e-6 and msgs[0].stamp is not None
            # back and forth over b again: no refire (b does not say refire)
            for k in range(24, -1, -1):
                st = ControllerState(stamp=3.0 + 0.1 * (24 - k), x=0.25 * k, y=0.1, yaw=0.0, v=1.0, curvature=0.0)
                me.link.put(me.keys.topic("controller", "state"), encode_body(st))
            ans = await retry(lambda: me.request("map_manager", "query", AnnotationQuery(type="set_speed"),
                                                  reply_type=AnnotationList))
            assert [r.used for r in ans.annotations] == [False, True, True]
            async with asyncio.timeout(10):
                while len(fired) < 2:
                    await asyncio.sleep(0.05)
            assert [(f.annotation_id, f.event, f.destination) for f in fired[:2]] == [("b", "fired", "vision"), ("c", "fired", "vision")]
            assert me.pending() == 0
    finally:
        for p in procs:
            stop(p)
