"""A client's frame cache answers exactly as the node does, without asking it (real node process, real Zenoh).

The node publishes every frame commit before acknowledging it or sending its monitor events, so a
client told of a commit through the blackboard has that commit's frames in its cache. A missed or
foreign update, or a node restart, empties the cache until the whole tree is fetched again; answers
the cache cannot give go to the node.
"""

from __future__ import annotations

import asyncio
import msgpack
import numpy as np
import pytest

from blackboard import BlackboardClient, Spec
from blackboard.errors import FutureExtrapolationError, PastExtrapolationError, UnknownFrameError
from blackboard.geometry import Pose2D
from blackboard.testing import start_node
from tests.blackboard.sample_types import Segment
from wire.keys import BlackboardKeys
from wire.session import open_session

FRAMES = ("world", "local", "vehicle", "camera")


async def _history(writer: BlackboardClient, rng: np.random.Generator, t0: float, n: int) -> None:
    """Post `n` uneven local←vehicle poses from `t0` [s] and a world←local correction now and then (held for ever)."""
    t = t0
    writes = []
    for i in range(n):
        t += float(rng.uniform(0.02, 0.2))
        writes.append(writer.post_pose(parent="local", child="vehicle", stamp=t, hold=0.3,
                                       pose=Pose2D(x=float(rng.normal(0, 20)), y=float(rng.normal(0, 20)), yaw=float(rng.uniform(-3, 3)))))
        if i % 17 == 0:
            writes.append(writer.post_pose(parent="world", child="local", stamp=t, hold=None,
                                           pose=Pose2D(x=float(rng.normal(100, 5)), y=float(rng.normal(-50, 5)), yaw=float(rng.normal(0, 0.1)))))
    await asyncio.gather(*writes)


async def _told(writer: BlackboardClient, mon, index: int) -> None:
    """Post a marker token and wait until the monitoring client heard of it (its frames came before it)."""
    await writer.post(Segment(index=index), stamp=0.0)
    ev = await mon.next(timeout=10.0)
    assert ev.token.attrs.index == index


async def _same_answers(cached: BlackboardClient, plain: BlackboardClient, rng: np.random.Generator, t_lo: float, t_hi: float, n: int = 60) -> None:
    """Ask both clients the same lookups (stamps across and beyond the history): the same answer or the same error."""
    for _ in range(n):
        a, b = rng.choice(FRAMES, size=2)
        sa = None if rng.random() < 0.1 else float(rng.uniform(t_lo - 1.0, t_hi + 1.0))
        sb = sa if rng.random() < 0.5 else float(rng.uniform(t_lo - 1.0, t_hi + 1.0))
        try:
            want = await plain.lookup(str(a), sa, str(b), sb)
        except (FutureExtrapolationError, PastExtrapolationError, UnknownFrameError) as exc:
            with pytest.raises(type(exc)):
                await cached.lookup(str(a), sa, str(b), sb)
            continue
        got = await cached.lookup(str(a), sa, str(b), sb)
        assert (got.x, got.y, got.yaw) == (want.x, want.y, want.yaw), (a, sa, b, sb)


async def test_the_cache_answers_as_the_node_does_and_without_it(node) -> None:
    rng = np.random.default_rng(7)
    async with BlackboardClient(node.client_net(), source="writer") as writer, \
            BlackboardClient(node.client_net(), source="cached", frame_cache=True) as cached:
        assert cached.frame_cache is not None and cached.frame_cache.ready
        await writer.set_static_frame(parent="vehicle", child="camera", pose=Pose2D(x=1.2, y=0.1, yaw=0.05))
        async with cached.monitor(Spec(type="bbt_segment")) as mon:
            await _history(writer, rng, 1000.0, 300)
            await _told(writer, mon, 1)
            stats = cached.frame_cache.stats
            hits = stats.hits
            await _same_answers(cached, writer, rng, 1000.0, 1000.0 + 300 * 0.11)
            assert stats.hits > hits + 20, stats.as_dict()  # most were answered here, not by the node
            pts = rng.normal(0.0, 10.0, size=(1000, 2))
            np.testing.assert_array_equal(
                await cached.transform(pts, src_frame="camera", src_stamp=1010.0, dst_frame="world"),
                await writer.transform(pts, src_frame="camera", src_stamp=1010.0, dst_frame="world"))

            # a foreign update on the wire (a wrong life, then garbage): the cache empties itself, fetches the
            # whole tree again and still answers as the node does
            primes = stats.primes
            s = open_session(node.client_net())
            try:
                s.put(BlackboardKeys(node.namespace).frame_updates, msgpack.packb(["not-the-node", 1, [["p", "local", "vehicle", 0.0, 0.0, 0.0, 1e6, 0.0]]]))
                s.put(BlackboardKeys(node.namespace).frame_updates, b"\xc1 not msgpack")
            finally:
                s.close()
            await _history(writer, rng, 1040.0, 50)
            await _told(writer, mon, 2)
            await cached.wait_frame_cache(primes + 1, timeout=10.0)
            await _told(writer, mon, 3)
            await _same_answers(cached, writer, rng, 1000.0, 1046.0)
            assert stats.gaps >= 1


async def test_a_restarted_node_refills_the_cache_from_its_new_life(tmp_path) -> None:
    db = str(tmp_path / "bb.db")
    rng = np.random.default_rng(3)
    n = start_node(namespace="fc", db=db, types=("tests.blackboard.sample_types",))
    port = int(n.endpoint.rsplit(":", 1)[1])
    try:
        async with BlackboardClient(n.client_net(), source="writer") as writer, \
                BlackboardClient(n.client_net(), source="cached", frame_cache=True) as cached:
            await _history(writer, rng, 0.0, 100)
            epoch = cached.frame_cache.epoch
            n.kill()
            await cached.wait_node(False, timeout=20.0)
            assert not cached.frame_cache.ready  # the node is away: nothing is answered from an old copy
            n = start_node(namespace="fc", db=db, port=port, types=("tests.blackboard.sample_types",))
            await cached.wait_resyncs(1, timeout=30.0)
            await writer.wait_resyncs(1, timeout=30.0)
            async with cached.monitor(Spec(type="bbt_segment")) as mon:
                await _history(writer, rng, 20.0, 100)
                await _told(writer, mon, 1)
                assert cached.frame_cache.ready and cached.frame_cache.epoch != epoch
                await _same_answers(cached, writer, rng, 0.0, 40.0)
    finally:
        n.stop()
