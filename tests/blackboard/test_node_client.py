"""Node and client over real Zenoh on loopback (node in its own process)."""

from __future__ import annotations

import asyncio
import json

import numpy as np
import pytest

from blackboard import (
    AttrPredicate,
    BadSpecError,
    BlackboardClient,
    FutureExtrapolationError,
    InvalidTokenError,
    NodeUnavailableError,
    NotFoundError,
    PastExtrapolationError,
    Point,
    Polygon,
    Pose2D,
    Spec,
    UnknownTypeError,
    VersionConflictError,
    Within,
    NetworkConfig,
)
from wire.session import open_session
from wire.keys import BlackboardKeys
from tests.blackboard.sample_types import Landmark, Obstacle, Segment

pytestmark = pytest.mark.timeout(60)


async def until(pred, timeout: float = 10.0):
    """Re-evaluate an async predicate (each a round trip to the node) until true or timeout."""
    async def loop():
        while not await pred():
            pass
    await asyncio.wait_for(loop(), timeout)


async def test_post_retrieve_round_trip_with_typed_attrs(bb):
    t = await bb.post(Landmark(name="rt-oak", height=3.0, tags=("a",)), geometry=Polygon(points=[(0, 0), (1, 0), (1, 1)]), stamp=1.5)
    assert t.version == 1 and t.source == "test" and t.type == "bbt_landmark" and t.id
    got = await bb.retrieve(Spec(type="bbt_landmark", where=[AttrPredicate(path="name", op="==", value="rt-oak")]))
    assert len(got) == 1
    g = got[0]
    assert isinstance(g.attrs, Landmark) and g.attrs == Landmark(name="rt-oak", height=3.0, tags=("a",))
    assert g.geometry == Polygon(points=[(0, 0), (1, 0), (1, 1)]) and g.stamp == 1.5 and g.id == t.id


async def test_cas_conflict_raises_typed_error(bb, node):
    t = await bb.post(Segment(index=1), stamp=0.0)
    async with BlackboardClient(node.client_net(), source="other") as other:
        await other.update(t.id, Segment(index=2), expected_version=1)
    with pytest.raises(VersionConflictError):
        await bb.update(t.id, Segment(index=3), expected_version=1)
    t3 = await bb.update(t.id, Segment(index=3), expected_version=2)
    assert t3.version == 3 and t3.attrs.index == 3
    await bb.delete(t.id)
    with pytest.raises(NotFoundError):
        await bb.delete(t.id)


async def test_typed_errors_come_back_as_exceptions(bb):
    with pytest.raises(UnknownTypeError):
        await bb.post_raw("no-such-type", {}, stamp=0.0)
    with pytest.raises(InvalidTokenError):
        await bb.post_raw("bbt_segment", {"index": "x"}, stamp=0.0)
    with pytest.raises(InvalidTokenError):
        await bb.post_raw("bbt_segment", {"index": 1}, stamp=0.0, geometry={"kind": "polygon", "points": [[0, 0], [1, 1]]})
    with pytest.raises(BadSpecError):
        await bb.retrieve_raw({"where": [{"path": "x", "op": "like"}]})
    # pipelined writes: each gets its own answer
    res = await asyncio.gather(
        bb.post(Segment(index=5), stamp=0.0), bb.post_raw("nope", {}, stamp=0.0), bb.post(Segment(index=6), stamp=0.0),
        return_exceptions=True,
    )
    assert res[0].attrs.index == 5 and isinstance(res[1], UnknownTypeError) and res[2].attrs.index == 6


async def test_wait_is_satisfied_by_a_later_post(bb, node):
    spec = Spec(type="bbt_obstacle", where=[AttrPredicate(path="confidence", op="==", value=0.25)])
    waiter = asyncio.create_task(bb.wait(spec, timeout=20))
    before = (await bb.stats()).monitors_registered
    await until(lambda: _stat_above(bb, "monitors_registered", before - 1))
    assert not waiter.done()
    async with BlackboardClient(node.client_net(), source="poster") as poster:
        await poster.post(Obstacle(confidence=0.5), stamp=1.0)
        posted = await poster.post(Obstacle(confidence=0.25), stamp=2.0)
    got = await waiter
    assert got.id == posted.id and got.attrs == Obstacle(confidence=0.25)
    # already there: answered at once
    assert (await bb.wait(spec, timeout=5)).id == posted.id
    with pytest.raises((asyncio.TimeoutError, TimeoutError)):
        await bb.wait(Spec(type="bbt_obstacle", where=[AttrPredicate(path="confidence", op="==", value=0.125)]), timeout=0.3)


async def _stat_above(bb, name, value):
    return getattr(await bb.stats(), name) > value


async def test_monitor_sees_new_updated_deleted_in_order(bb, node):
    region = Within(Polygon(points=[(100, 100), (110, 100), (110, 110), (100, 110)]))
    async with bb.monitor(Spec(type="bbt_landmark", geometry=region)) as mon:
        async with BlackboardClient(node.client_net(), source="writer") as w:
            a = await w.post(Landmark(name="m-a"), geometry=Point(x=105, y=105), stamp=1.0)
            await w.post(Landmark(name="m-outside"), geometry=Point(x=0, y=0), stamp=1.0)
            a2 = await w.update(a.id, Landmark(name="m-a2"), expected_version=1)
            await w.delete(a.id)
            burst = await asyncio.gather(*[w.post(Landmark(name=f"m-{i}"), geometry=Point(x=101 + i * 0.1, y=101), stamp=2.0) for i in range(20)])
        evs = [await mon.next(10) for _ in range(23)]
    assert [(e.kind, e.token.id) for e in evs[:3]] == [("new", a.id), ("updated", a.id), ("deleted", a.id)]
    assert evs[1].token.version == 2 and evs[1].token.attrs == a2.attrs
    assert [e.token.id for e in evs[3:]] == [t.id for t in burst]
    assert all(e.kind == "new" for e in evs[3:])


async def test_poses_lookup_transform_and_extrapolation_errors(bb):
    await bb.set_static_frame(parent="vehicle", child="camera", pose=Pose2D(x=1.0, y=0.0, yaw=0.0))
    await bb.post_pose(parent="world", child="local", pose=Pose2D(x=100, y=0, yaw=0), stamp=0.0, hold=None)
    await asyncio.gather(*[bb.post_pose(parent="local", child="vehicle", pose=Pose2D(x=float(t), y=0, yaw=0), stamp=float(t)) for t in range(11)])
    p = await bb.lookup_pose(parent="world", child="vehicle", stamp=2.5)
    assert p.x == pytest.approx(102.5) and p.yaw == pytest.approx(0.0)
    pts = np.array([[1.0, 0.0], [0.0, 1.0]])
    out = await bb.transform(pts, src_frame="camera", src_stamp=2.0, dst_frame="world")
    np.testing.assert_allclose(out, [[104.0, 0.0], [103.0, 1.0]])
    out = await bb.transform(pts, src_frame="vehicle", src_stamp=2.0, dst_frame="vehicle", dst_stamp=5.0)
    np.testing.assert_allclose(out, [[-2.0, 0.0], [-3.0, 1.0]])
    with pytest.raises(FutureExtrapolationError):
        await bb.lookup_pose(parent="local", child="vehicle", stamp=11.5)
    with pytest.raises(PastExtrapolationError):
        await bb.lookup_pose(parent="local", child="vehicle", stamp=-1.0)
    # a token "relative to the vehicle at t" is retrieved in world
    o = await bb.post(Obstacle(confidence=0.75), frame="vehicle", geometry=Point(x=3, y=0), stamp=4.0)
    (w,) = [t for t in await bb.retrieve(Spec(type="bbt_obstacle"), frame="world") if t.id == o.id]
    assert w.frame == "world" and w.geometry.x == pytest.approx(107.0)


async def test_json_endpoints_answer_json_for_standard_tools(node):
    keys = BlackboardKeys(node.namespace)
    s = open_session(NetworkConfig(namespace=node.namespace, connect=(node.endpoint,)))
    try:
        loop = asyncio.get_running_loop()

        async def zget(key, body):
            fut = loop.create_future()
            s.get(key, json.dumps(body).encode(), as_json=True, timeout=10,
                  on_reply=lambda r: loop.call_soon_threadsafe(lambda: fut.done() or fut.set_result(r)),
                  on_done=lambda: loop.call_soon_threadsafe(lambda: fut.done() or fut.set_exception(TimeoutError(key))))
            return await fut

        r = await zget(keys.post, {"type": "bbt_segment", "attrs": {"index": 77}, "stamp": 3.0, "geometry": {"kind": "point", "x": 500, "y": 500}})
        assert r.ok and r.is_json
        tok = json.loads(r.payload)
        assert tok["attrs"] == {"index": 77, "mode": "follow-road"} and tok["version"] == 1
        r = await zget(keys.retrieve, {"type": "bbt_segment", "where": [{"path": "index", "op": "==", "value": 77}]})
        assert r.ok and r.is_json and [t["id"] for t in json.loads(r.payload)] == [tok["id"]]
        r = await zget(keys.retrieve, {"type": 12})
        assert not r.ok and json.loads(r.payload)["error"] == "bad_spec"
        r = await zget(keys.post, {"type": "zzz"})
        assert not r.ok and json.loads(r.payload)["error"] == "unknown_type"
    finally:
        s.close()


async def test_stats_count_operations(bb):
    s0 = await bb.stats()
    await bb.post(Segment(index=900), stamp=0.0)
    await bb.retrieve(Spec(type="bbt_segment"))
    s1 = await bb.stats()
    assert s1.posts == s0.posts + 1 and s1.retrieves == s0.retrieves + 1
    assert s1.bytes_in > s0.bytes_in and s1.bytes_out > s0.bytes_out and s1.tokens >= 1


async def test_monitors_of_a_vanished_client_are_dropped(bb, node):
    c = BlackboardClient(node.client_net(), source="short-lived")
    await c.open()
    await c.monitor(Spec(type="bbt_segment")).start()
    assert (await bb.stats()).monitors >= 1
    # close the session without cancelling: the node must notice via liveliness
    c._monitors.clear()
    await c.close()
    await until(lambda: _stat_equals(bb, "monitors", 0), timeout=15)


async def _stat_equals(bb, name, value):
    return getattr(await bb.stats(), name) == value


async def test_client_without_node_fails_with_node_unavailable():
    from wire.ports import free_port

    net = NetworkConfig(namespace="nobody", connect=(f"tcp/127.0.0.1:{free_port()}",))
    with pytest.raises(NodeUnavailableError):
        await BlackboardClient.connect(net, connect_timeout=0.5)


async def test_loop_dispatch_mode_serves_the_same_api():
    from blackboard.testing import start_node

    with start_node(namespace="loopmode", types=("tests.blackboard.sample_types",), dispatch="loop") as n:
        async with BlackboardClient(n.client_net(), source="loop") as bb:
            async with bb.monitor(Spec(type="bbt_segment")) as mon:
                toks = await asyncio.gather(*[bb.post(Segment(index=i), stamp=float(i)) for i in range(50)])
                evs = [await mon.next(10) for _ in range(50)]
            assert [e.token.id for e in evs] == [t.id for t in toks]
            assert len(await bb.retrieve(Spec(type="bbt_segment", where=[AttrPredicate(path="index", op=">=", value=25)]))) == 25


async def test_closing_a_monitor_ends_its_iteration(bb):
    mon = await bb.monitor(Spec(type="bbt_segment", where=[AttrPredicate(path="index", op="==", value=31337)])).start()
    got = asyncio.Event()
    seen = []

    async def consume():
        async for ev in mon:
            seen.append(ev.token.id)
            got.set()

    task = asyncio.create_task(consume())
    t = await bb.post(Segment(index=31337), stamp=0.0)
    await asyncio.wait_for(got.wait(), 10)
    await mon.close()
    await asyncio.wait_for(task, 10)  # the async for ends instead of hanging
    assert seen == [t.id]
