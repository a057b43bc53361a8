"""The put-based write channel: `bb/write/<client>` → commit → `bb/to/<client>` (real nodes over Zenoh)."""

from __future__ import annotations

import asyncio
import os
import signal
import threading

import msgpack
import pytest

from blackboard import AttrPredicate, BlackboardClient, NodeUnavailableError, Spec
from wire.session import open_session
from wire.keys import BlackboardKeys
from blackboard.testing import start_node
from wire.ports import free_port
from tests._procs import wait_stopped
from tests.blackboard.sample_types import Landmark, Segment

pytestmark = pytest.mark.timeout(90)

TYPES = ("tests.blackboard.sample_types",)


def _observer(node, key: str, on_message) -> object:
    """Open a raw zenoh session subscribed to `key`; `on_message(key, [acks, events])` on a zenoh thread."""
    s = open_session(node.client_net())
    s.subscribe_payload(key, lambda k, payload: on_message(k, msgpack.unpackb(payload)))
    return s


async def test_a_write_is_acknowledged_only_once_durable(tmp_path):
    """SIGKILL the node the instant its acknowledgement is seen on the wire: the token survives a restart."""
    db = str(tmp_path / "bb.sqlite")
    port = free_port()
    node = start_node(namespace="wc1", port=port, db=db, types=TYPES)
    loop = asyncio.get_running_loop()
    seen: asyncio.Future = loop.create_future()
    acked_ids: list[str] = []

    def on_message(key: str, msg: list) -> None:
        acks, _events = msg
        for _rid, results in acks:
            acked_ids.extend(r["ok"]["id"] if isinstance(r["ok"], dict) else r["ok"] for r in results if "ok" in r)
        if acks:
            os.kill(node.proc.pid, signal.SIGKILL)  # no time for anything after the ack
            loop.call_soon_threadsafe(lambda: seen.done() or seen.set_result(None))

    obs = _observer(node, "sidewalk/wc1/bb/to/*", on_message)
    try:
        async with BlackboardClient(node.client_net(), source="w", timeout=10.0, reconnect=False) as bb:
            futs = [bb.post(Landmark(name=f"durable-{k}"), stamp=1.0) for k in range(5)]
            await asyncio.wait_for(seen, 20)
            await asyncio.gather(*futs, return_exceptions=True)
    finally:
        obs.close()
        node.kill()
        node.stop()
    assert acked_ids
    node2 = start_node(namespace="wc1", port=port, db=db, types=TYPES)
    try:
        async with BlackboardClient(node2.client_net(), source="check") as bb:
            stored = {t.id for t in await bb.retrieve(Spec(type="bbt_landmark"))}
        assert set(acked_ids) <= stored
    finally:
        node2.stop()


async def test_acknowledgements_reach_only_their_own_client():
    """Two clients reuse the same request ids; each gets its own results, and a foreign writer's ack goes elsewhere."""
    with start_node(namespace="wc2", types=TYPES) as node:
        keys = BlackboardKeys("wc2")
        async with BlackboardClient(node.client_net(), source="alice") as a, BlackboardClient(node.client_net(), source="bob") as b:
            loop = asyncio.get_running_loop()
            seen_by_a: list[list] = []
            got = asyncio.Event()

            def on_a(m: list) -> None:
                seen_by_a.append(m)
                got.set()

            foreign: asyncio.Future = loop.create_future()
            obs = _observer(node, keys.to_client(a.client_id), lambda k, m: loop.call_soon_threadsafe(on_a, m))
            obs_x = _observer(node, keys.to_client("intruder"), lambda k, m: loop.call_soon_threadsafe(
                lambda: foreign.done() or foreign.set_result(m)))
            try:
                fa = [a.post_raw("bbt_segment", {"index": i, "mode": "alice"}, stamp=0.0) for i in range(100)]
                fb = [b.post_raw("bbt_segment", {"index": i, "mode": "bob"}, stamp=0.0) for i in range(100)]
                ra, rb = await asyncio.gather(asyncio.gather(*fa), asyncio.gather(*fb))
                assert [(t["attrs"]["index"], t["attrs"]["mode"], t["source"]) for t in ra] == [(i, "alice", "alice") for i in range(100)]
                assert [(t["attrs"]["index"], t["attrs"]["mode"], t["source"]) for t in rb] == [(i, "bob", "bob") for i in range(100)]
                # a raw writer calling itself "intruder" uses request id 1, like every client's first batch
                obs_x.put(keys.write("intruder"), msgpack.packb([1, [{"op": "post", "type": "bbt_segment", "attrs": {"index": -1},
                                                                      "stamp": 0.0, "source": "x"}]]))
                (rid, results), = (await asyncio.wait_for(foreign, 10))[0]
                assert rid == 1 and "ok" in results[0]
                n_before = len(seen_by_a)
                t = await a.post(Segment(index=5), stamp=0.0)  # a round trip: every earlier message reached `obs`
                assert t.version == 1
                while len(seen_by_a) <= n_before:  # the observer's copy of that ack
                    got.clear()
                    await asyncio.wait_for(got.wait(), 10)
                a_rids = [rid for acks, _ in seen_by_a for rid, _ in acks]
                assert a_rids == list(range(1, len(a_rids) + 1))  # alice's own batches, each once, in order
                assert not any(isinstance(r.get("ok"), dict) and r["ok"]["source"] == "x"
                               for acks, _ in seen_by_a for _, res in acks for r in res)
            finally:
                obs.close()
                obs_x.close()


async def test_pending_writes_fail_with_node_unavailable_not_hang():
    """Without `reconnect`: a frozen node: writes time out; a dead node: writes in flight fail at once, well before the timeout."""
    node = start_node(namespace="wc3", types=TYPES)
    try:
        async with BlackboardClient(node.client_net(), source="t", timeout=1.0, reconnect=False) as quick, \
                BlackboardClient(node.client_net(), source="t2", timeout=60.0, reconnect=False) as slow:
            await quick.post(Segment(index=1), stamp=0.0)
            os.kill(node.proc.pid, signal.SIGSTOP)  # alive (liveliness holds) but not answering
            # kill() returns before the stop takes effect: one thread takes it and stops the others when it
            # next runs, and meanwhile the node's Zenoh threads may still commit and acknowledge a write
            wait_stopped(node.proc.pid)
            try:
                with pytest.raises(NodeUnavailableError, match="no acknowledgement"):
                    await asyncio.wait_for(quick.post(Segment(index=2), stamp=0.0), 10)
                in_flight = [slow.post(Segment(index=3 + k), stamp=0.0) for k in range(10)]
                node.kill()  # SIGKILL while frozen: the writes were sent, never acknowledged
            finally:
                if node.proc.poll() is None:
                    os.kill(node.proc.pid, signal.SIGCONT)
            outcomes = await asyncio.wait_for(asyncio.gather(*in_flight, return_exceptions=True), 20)  # not the 60 s timeout
            assert all(isinstance(o, NodeUnavailableError) for o in outcomes)
            assert "went away" in str(outcomes[0])
    finally:
        node.kill()
        node.stop()


async def test_node_restart_serves_clients_again(tmp_path):
    """Writes to a node that died fail; a client opened on the restarted node finds what was acknowledged."""
    db = str(tmp_path / "bb.sqlite")
    port = free_port()
    node = start_node(namespace="wc4", port=port, db=db, types=TYPES)
    async with BlackboardClient(node.client_net(), source="a", timeout=5.0, reconnect=False) as bb:
        ok = await bb.post(Landmark(name="kept"), stamp=0.0)
        node.kill()
        node.stop()
        with pytest.raises(NodeUnavailableError):
            await asyncio.wait_for(bb.post(Landmark(name="lost"), stamp=0.0), 20)
    node2 = start_node(namespace="wc4", port=port, db=db, types=TYPES)
    try:
        async with BlackboardClient(node2.client_net(), source="b") as bb:
            names = [t.attrs.name for t in await bb.retrieve(Spec(type="bbt_landmark"))]
            assert "kept" in names and ok.id in {t.id for t in await bb.retrieve(
                Spec(type="bbt_landmark", where=[AttrPredicate(path="name", op="==", value="kept")]))}
    finally:
        node2.stop()


async def test_a_burst_of_writes_leaves_in_bounded_messages_the_first_full_one_at_once():
    """1 + 3 × MAX + 7 posts issued without yielding: the first alone, then messages of at most MAX writes,
    each full one on the wire before the burst is over; every post stored once, in call order."""
    from blackboard.client import MAX_WRITES_PER_MESSAGE as cap

    n = 1 + 3 * cap + 7
    with start_node(namespace="wc5", types=TYPES) as node:
        keys = BlackboardKeys("wc5")
        async with BlackboardClient(node.client_net(), source="burst") as bb:
            await bb.post(Segment(index=-1), stamp=0.0)  # the write channel is up
            before = await bb.stats()
            sizes: list[int] = []
            first_full, seen_all = threading.Event(), threading.Event()

            def on_write(_key: str, msg: list) -> None:
                sizes.append(len(msg[1]))
                if len(msg[1]) == cap:
                    first_full.set()
                if sum(sizes) == n:
                    seen_all.set()

            obs = _observer(node, keys.write(bb.client_id), on_write)
            try:
                await bb.post(Segment(index=-2), stamp=0.0)  # a round trip: the observer's subscription is matched
                sizes.clear()
                futs = [bb.post(Segment(index=k), stamp=0.0) for k in range(1 + cap)]
                # still inside the loop iteration that issued them: the full message is already on the wire
                assert first_full.wait(10), f"no full message left during the burst; seen {sizes}"
                futs += [bb.post(Segment(index=k), stamp=0.0) for k in range(1 + cap, n)]
                tokens = await asyncio.wait_for(asyncio.gather(*futs), 30)
                assert seen_all.wait(10), sizes  # the observer's copies of the last messages
            finally:
                obs.close()
            after = await bb.stats()
        assert [t.attrs.index for t in tokens] == list(range(n))
        ids = [int(t.id[1:]) for t in tokens]
        assert ids == sorted(ids) and len(set(ids)) == n  # committed in call order, each once
        assert max(sizes) == cap and sum(sizes) == n, sizes
        assert sizes[0] == 1  # the first write of an iteration goes alone, as before
        assert after.write_requests - before.write_requests == len(sizes) + 1  # + the round trip above
        assert after.posts - before.posts == n + 1


async def test_a_retrieve_travels_the_write_channel_behind_the_writes_issued_before_it():
    """1 + MAX + 40 posts issued without yielding, then a retrieve: it leaves on `bb/write/<client>` after the
    last of their messages and finds every one; a bad spec and an unknown read come back as typed errors."""
    from blackboard import BadRequestError, BadSpecError
    from blackboard.client import MAX_WRITES_PER_MESSAGE as cap

    n = 1 + cap + 40
    with start_node(namespace="wc6", types=TYPES) as node:
        keys = BlackboardKeys("wc6")
        async with BlackboardClient(node.client_net(), source="reader") as bb:
            await bb.post(Segment(index=-1), stamp=0.0)
            kinds: list[str] = []
            seen_read = threading.Event()

            def on_write(_key: str, msg: list) -> None:
                kinds.append(msg[1] if len(msg) == 3 else f"write×{len(msg[1])}")
                if len(msg) == 3:
                    seen_read.set()

            obs = _observer(node, keys.write(bb.client_id), on_write)
            try:
                await bb.post(Segment(index=-2), stamp=0.0)  # a round trip: the observer's subscription is matched
                kinds.clear()
                futs = [bb.post(Segment(index=k), stamp=0.0) for k in range(n)]
                got = await asyncio.wait_for(bb.retrieve(Spec(type="bbt_segment", where=[
                    AttrPredicate(path="index", op=">=", value=0)])), 20)
                assert seen_read.wait(10), kinds
                await asyncio.wait_for(asyncio.gather(*futs), 20)
            finally:
                obs.close()
            assert sorted(t.attrs.index for t in got) == list(range(n))
            assert kinds == ["write×1", f"write×{cap}", "write×40", "retrieve"], kinds
            with pytest.raises(BadSpecError):
                await asyncio.wait_for(bb.retrieve_raw({"type": "bbt_segment", "limit": -3}), 10)
            with pytest.raises(BadRequestError, match="unknown read"):
                await asyncio.wait_for(bb._read("frobnicate", {}), 10)
            assert len(await bb.retrieve(Spec(type="bbt_segment"))) == n + 2  # the node serves on
