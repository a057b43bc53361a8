"""The monitor's model and adapters: CODGER tokens and frames, EDDIE streams (over real Zenoh on loopback),
module health, position error, and the page server's frames (websocket, latest value wins)."""

from __future__ import annotations

import asyncio
import json
import math

import aiohttp
import msgpack
import pytest

from sidewalk.monitor.codger import CodgerInterpreter
from sidewalk.monitor.eddie import EddieInterpreter
from sidewalk.monitor.model import MonitorModel, XYPose
from sidewalk.monitor.server import MonitorServer, PortInUseError, check_port
from sidewalk.monitor.sources import SimSource
from wire.health import Heartbeat
from wire.ports import free_port


class FakeFrames:
    """world←vehicle@t = (10 + t, 0, π/2); world←local = (100, 0, 0)."""

    async def world_from(self, frame, stamp):
        return {"vehicle": (10.0 + stamp, 0.0, math.pi / 2), "local": (100.0, 0.0, 0.0)}.get(frame)


def tok(ttype, attrs, *, event_id="t", frame="world"):
    return {"id": event_id, "type": ttype, "version": 1, "stamp": 1.0, "source": "x", "frame": frame, "geometry": None, "attrs": attrs}


async def test_codger_tokens_become_what_the_page_draws():
    m = MonitorModel(arch="codger")
    c = CodgerInterpreter(m, FakeFrames())
    line = [[0, 0], [0, 10]]
    await c.on_token("new", tok("route_plan", {"mission_id": "m", "step_index": 0, "revision": 1, "polyline": line}))
    await c.on_token("new", tok("route_plan", {"mission_id": "m", "step_index": 0, "revision": 0, "polyline": [[5, 5], [6, 6]]}))
    assert m.section("route")[0]["points"] == ((0.0, 0.0), (0.0, 10.0))  # an older revision never replaces a newer one
    await c.on_token("new", tok("route_segment", {"segment_id": "s1", "centreline": line, "width_m": 2.0, "mode": "follow-road"}))
    assert m.section("segment")["id"] == "s1"
    await c.on_token("updated", tok("route_segment", {"segment_id": "s1", "centreline": line, "state": "cancelled"}))
    assert m.section("segment") is None
    unit = {"unit_id": "u1", "unit_index": 0, "status": "perceived", "mode": "follow-road", "region": [[0, 0], [2, 0], [2, 2]],
            "centreline": line}
    await c.on_token("updated", tok("driving_unit", unit))
    assert m.section("perceived") == []  # the unit carries only its status; what PERCEPTION saw is its own token
    await c.on_token("new", tok("perception_result", {"unit_id": "u1", "status": "perceived", "captured_at": 2.0, "frame": "vehicle",
                                                      "navigable_region": [[1, 0], [2, 0], [2, 1]], "view_frame": [[0, 0], [5, -2], [5, 2]],
                                                      "detected": [{"outline": [[1, 1], [2, 1], [2, 2]]}], "extra": "ignored"}))
    (u,) = m.section("units")
    assert u["id"] == "u1" and u["status"] == "perceived"
    (p,) = m.section("perceived")
    # vehicle@2 → world: (12, 0) + rotation by π/2: (x, y) → (12 - y, x)
    assert p["navigable_region"][0] == pytest.approx((12.0, 1.0)) and p["view_frame"][1] == pytest.approx((14.0, 5.0))
    assert len(p["detected"]) == 1
    await c.on_token("updated", tok("driving_unit", {**unit, "status": "cancelled"}))
    assert m.section("units") == [] and m.section("perceived") == []
    await c.on_token("new", tok("local_path_plan", {"seq": 1, "frame": "local", "poses": [{"x": 0, "y": 0}, {"x": 1, "y": 0}]}))
    assert m.section("plan")["points"] == []  # no world←local yet: nothing to draw it through
    c.on_world_from_local(3.0, 100.0, 0.0, 0.0)
    assert m.section("plan")["points"] == [[100.0, 0.0], [101.0, 0.0]]
    await c.on_token("new", tok("mission_status", {"mission_id": "m", "name": "x", "state": "running", "step_count": 1}))
    assert m.section("mission")["state"] == "running"


def test_eddie_estimate_is_world_from_local_after_the_controller_pose():
    m = MonitorModel(arch="eddie")
    e = EddieInterpreter(m)
    assert e.on_sample("eddie/pub/controller/state", {"stamp": 4.0, "x": 1.0, "y": 0.0, "yaw": 0.0, "v": 1.5, "curvature": 0.1,
                                                      "client": "road_follower", "mode": "track", "unknown_field": [1, 2]})
    assert m.section("estimate") is None  # no world←local yet
    e.on_sample("eddie/pub/navigator/world_from_local", {"stamp": 4.0, "x": 10.0, "y": 5.0, "yaw": math.pi / 2})
    est = m.section("estimate")
    assert (est["x"], est["y"], est["yaw"]) == pytest.approx((10.0, 6.0, math.pi / 2))
    e.on_sample("eddie/pub/controller/path", {"stamp": 4.0, "path": [[0, 0], {"x": 2, "y": 0}]})
    ctl = m.section("controller")
    assert [tuple(p) for p in ctl["path"]] == [(10.0, 5.0), (10.0, 7.0)] and ctl["client"] == "road_follower" and ctl["v"] == 1.5
    e.on_sample("eddie/pub/map_manager/triggers", {"stamp": 5.0, "annotation_id": "a7", "trigger_type": "wake", "destination": "landmark",
                                                   "x": 3.0, "y": 4.0, "text": "start matching"})
    (t,) = m.section("triggers")
    assert (t["annotation_id"], t["type"], t["destination"], t["x"]) == ("a7", "wake", "landmark", 3.0)
    e.on_annotations({"annotations": [{"id": "a7", "type": "landmark", "polygon": [[0, 0], [1, 0], [1, 1]]},
                                      {"id": "a8", "type": "stop", "location": {"kind": "point", "points": [[5, 5]]}},
                                      {"id": "bad"}]})
    assert [a["id"] for a in m.section("annotations")] == ["a7", "a8"]
    assert not e.on_sample("sim/truth", {"x": 1})


def _route_annotation(aid, index, points, mode="follow-road"):
    import base64

    from eddie.messages.map_manager import RouteSegment, encode_trigger_data

    data = encode_trigger_data(RouteSegment(index=index, mode=mode, points=tuple(points), width=2.5, speed=1.0))
    # the record's own location is deliberately not the centreline: the segment's data is what counts
    return {"id": aid, "type": "route", "kind": "line", "points": [[-50, -50], [-60, -60]], "text": f"segment {index}",
            "data_base64": base64.b64encode(data).decode()}


def test_eddie_route_and_current_segment_from_the_route_annotations():
    m = MonitorModel(arch="eddie")
    e = EddieInterpreter(m)
    # an out-and-back route: out along y = 0, back along y = 1 (1 m apart), answered out of order
    anns = [_route_annotation("r2", 2, [(20, 1), (0, 1)]), _route_annotation("r0", 0, [(0, 0), (10, 0)]),
            _route_annotation("r1", 1, [(10, 0), (20, 0), (20, 1)], mode="turn-at-intersection"),
            {"id": "s", "type": "set_speed", "points": [[5, -1], [5, 1]]}]
    e.on_annotations({"annotations": anns})
    (route,) = m.section("route")
    assert route["points"] == ((0, 0), (10, 0), (20, 0), (20, 1), (0, 1))
    assert m.section("segment") is None  # no pose yet
    e.on_sample("eddie/pub/navigator/world_from_local", {"stamp": 0.0, "x": 0.0, "y": 0.0, "yaw": 0.0})

    def at(x, y):
        e.on_sample("eddie/pub/controller/state", {"stamp": 1.0, "x": x, "y": y, "yaw": 0.0, "v": 1.0})
        return m.section("segment")

    assert at(2.0, 0.2)["id"] == "r0"
    seg = at(15.0, 0.3)
    assert (seg["id"], seg["mode"], seg["width_m"]) == ("r1", "turn-at-intersection", 2.5)
    assert seg["centreline"] == ((10, 0), (20, 0), (20, 1))
    assert at(12.0, 0.9)["id"] == "r2"  # nearer the way back than the way out
    assert at(5.0, 0.2)["id"] == "r2"  # a segment passed is not taken again
    # a skipped trigger keeps its outcome
    e.on_sample("eddie/pub/map_manager/triggers", {"stamp": 5.0, "annotation_id": "s", "trigger_type": "set_speed",
                                                   "destination": "controller", "x": 5.0, "y": 0.0, "event": "skipped", "via": "jump"})
    (t,) = m.section("triggers")
    assert (t["event"], t["via"]) == ("skipped", "jump")
    e.on_sample("eddie/pub/controller/events", {"stamp": 6.0, "kind": "refused", "client": "vision", "detail": "lower priority"})
    (ev,) = m.section("events")
    assert (ev["kind"], ev["object_id"], ev["detail"]) == ("controller refused", "vision", "lower priority")


def test_module_health_alive_wedged_gone_and_position_error():
    now = [1000.0]
    m = MonitorModel(wall=lambda: now[0])
    s = SimSource(m)
    s.on_alive("pilot", True)
    s.on_alive("bbclient/x", True)  # blackboard clients are not processes of the list
    m.heartbeat(Heartbeat(module="pilot", seq=1, wall_time=1.0, period_s=1.0, pid=7), received=1000.0)
    now[0] = 1001.0
    (row,) = m.modules()
    assert (row.name, row.state, row.alive, row.age_s) == ("pilot", "ready", True, 1.0)
    now[0] = 1003.5  # alive by its token, silent for more than 3 s: wedged
    assert m.modules()[0].state == "wedged"
    s.on_alive("pilot", False)
    assert m.modules()[0].state == "gone"
    s.on_sample("sim/truth", {"stamp": 1.0, "x": 0.0, "y": 0.0, "yaw": 0.0, "v": 1.0})
    s.on_sample("sim/truth", {"stamp": 2.0, "x": 1.0, "y": 0.0, "yaw": 0.0, "v": 1.0})
    m.set_estimate(XYPose(t=1.5, x=0.5, y=0.3, yaw=0.0))
    assert m.section("series")["pos_error"] == [(1.5, 0.3)]
    assert m.section("series")["speed"][0] == (1.0, 1.0)
    assert m.section("meta")["sim_time"] == 2.0


async def test_page_server_sends_every_section_first_then_coalesced_changes():
    m = MonitorModel()
    port = free_port()
    srv = MonitorServer(m, "127.0.0.1", port)
    await srv.start()
    try:
        with pytest.raises(PortInUseError, match=f"port {port} on 127.0.0.1 is in use"):
            check_port("127.0.0.1", port)
        async with aiohttp.ClientSession() as http:
            async with http.get(srv.url) as r:
                assert r.status == 200 and "NAVIGATION MONITOR" in await r.text()
            async with http.get(srv.url + "static/monitor.js") as r:
                assert r.status == 200 and "monitorState" in await r.text()
            async with http.get(srv.url + "static/../server.py") as r:
                assert r.status == 404
            async with http.get(srv.url + "image/camera") as r:
                assert r.status == 404
            m.image("camera", b"\xff\xd8jpeg", width=4, height=3, stamp=1.0)
            async with http.get(srv.url + "image/camera") as r:
                assert r.status == 200 and r.content_type == "image/jpeg" and await r.read() == b"\xff\xd8jpeg"
            async with http.ws_connect(srv.url + "ws") as ws:
                first = json.loads((await ws.receive(timeout=10)).data)["sections"]
                assert set(first) >= {"meta", "map", "route", "units", "modules", "images"}
                for i in range(2000):  # a burst of updates in one loop turn
                    m.set_truth(XYPose(t=float(i), x=float(i), y=0.0, yaw=0.0), 1.0)
                frame = json.loads((await ws.receive(timeout=10)).data)["sections"]
                assert frame["truth"]["x"] == 1999.0  # the newest value, the 1999 before it were skipped
                assert "map" not in frame  # unchanged sections are not sent again
    finally:
        await srv.stop()


async def test_eddie_adapter_over_zenoh(tmp_path):
    """EDDIE's streams and its annotation service, served by a plain peer, reach the model and the page."""
    from runtime import ModuleRuntime
    from sidewalk.monitor.live import LiveMonitor
    from wire.aio import Link, QueryAnswer
    from wire.keys import Keys
    from wire.network import NetworkConfig

    ep = f"tcp/127.0.0.1:{free_port()}"
    ns = "eddiemon"
    k = Keys(ns)
    eddie_side = Link.open(NetworkConfig(namespace=ns, listen=(ep,)))
    mon_link = Link.open(NetworkConfig(namespace=ns, connect=(ep,)))
    asked = []

    async def annotations(req):
        asked.append(json.loads(req.payload))
        return QueryAnswer(ok=True, payload=json.dumps([{"id": "a1", "type": "landmark", "polygon": [[0, 0], [2, 0], [2, 2]]}]).encode(),
                           as_json=True)

    eddie_side.queryable(k.eddie.service("map_manager", "query"), annotations)
    model = MonitorModel(arch="eddie")
    rt = ModuleRuntime("monitor", mon_link.net, mon_link)
    live = LiveMonitor(rt, model, arch="eddie")
    changed = asyncio.Event()
    model.listen(changed)
    try:
        await mon_link.wait_connected(10.0)
        await live.start()
        pack = msgpack.packb
        loop = asyncio.get_running_loop()
        deadline = loop.time() + 20.0
        while loop.time() < deadline:
            eddie_side.put(k.eddie.topic("navigator", "world_from_local"), pack({"stamp": 1.0, "x": 10.0, "y": 0.0, "yaw": 0.0}))
            eddie_side.put(k.eddie.topic("controller", "state"), pack({"stamp": 1.0, "x": 2.0, "y": 1.0, "yaw": 0.0, "v": 0.8,
                                                                         "curvature": 0.0, "client": "vision", "mode": "track", "new": True}))
            eddie_side.put(k.eddie.topic("map_manager", "triggers"), pack({"stamp": 1.0, "annotation_id": "a1", "trigger_type": "enter",
                                                                            "destination": "obstacle", "x": 1.0, "y": 1.0, "text": "t"}))
            if model.estimate is not None and model.triggers and model.annotations:
                break
            changed.clear()
            try:
                await asyncio.wait_for(changed.wait(), 0.5)  # the next change, or publish again
            except asyncio.TimeoutError:
                pass
        assert (model.estimate.x, model.estimate.y) == (12.0, 1.0)
        assert model.section("controller")["client"] == "vision"
        assert model.triggers[0]["destination"] == "obstacle"
        assert model.section("annotations")[0]["id"] == "a1" and asked[0] == {"type": None, "polygon": None}
    finally:
        await live.stop()
        mon_link.close()
        eddie_side.close()
