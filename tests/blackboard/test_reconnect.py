"""Reconnection: a client keeps working across a SIGKILLed and restarted node (same database, same
endpoint): its monitors are registered again and deliver events, writes made while the node was
away are held and stored once it is back, queries wait for it instead of failing."""

import asyncio
import time

from blackboard import BlackboardClient, Spec
from blackboard.testing import start_node
from tests.blackboard.sample_types import Landmark, Segment
from wire.ports import free_port

TYPES = ("tests.blackboard.sample_types",)


async def test_monitor_delivers_again_after_the_node_is_killed_and_restarted(tmp_path):
    db = str(tmp_path / "bb.sqlite")
    port = free_port()
    node = start_node(namespace="rc1", port=port, db=db, types=TYPES)
    node2 = None
    try:
        async with BlackboardClient(node.client_net(), source="watcher", timeout=5.0) as bb:
            mon = bb.monitor(Spec(type="bbt_landmark"))
            await mon.start()
            await bb.post(Landmark(name="before"), stamp=0.0)
            assert (await mon.next(timeout=10)).token.attrs.name == "before"

            node.kill()
            await bb.wait_node(alive=False, timeout=30)
            # made while the node is away: held, not failed
            held_post = bb.post(Segment(index=7), stamp=1.0)
            held_query = asyncio.ensure_future(bb.retrieve(Spec(type="bbt_segment")))
            await asyncio.sleep(0)
            assert not held_post.done() and not held_query.done()

            node2 = start_node(namespace="rc1", port=port, db=db, types=TYPES)
            t_ready = time.monotonic()
            await bb.wait_resyncs(1, timeout=30)
            # the held write was stored once, the held query answered from the restarted node
            tok = await asyncio.wait_for(held_post, 30)
            assert tok.attrs.index == 7
            segs = await asyncio.wait_for(held_query, 30)
            assert all(s.attrs.index == 7 for s in segs)
            assert [s.id for s in await bb.retrieve(Spec(type="bbt_segment"))] == [tok.id]
            assert (await bb.stats()).monitors == 1  # registered again on the new node

            # another client posts on the restarted node: the old monitor sees it
            async with BlackboardClient(node2.client_net(), source="poster") as other:
                await other.post(Landmark(name="after"), stamp=2.0)
            ev = await mon.next(timeout=10)
            print(f"node ready -> re-registered monitor event: {time.monotonic() - t_ready:.3f} s")
            assert ev.kind == "new" and ev.token.attrs.name == "after"
            # what was acknowledged before the kill is still there
            assert {t.attrs.name for t in await bb.retrieve(Spec(type="bbt_landmark"))} == {"before", "after"}
    finally:
        node.kill()
        if node2 is not None:
            node2.stop()


async def test_a_retrieve_in_flight_when_the_node_dies_is_asked_again_of_the_restarted_node(tmp_path):
    """A retrieve sent to a frozen node that is then SIGKILLed neither fails nor hangs: it is held and
    answered by the restarted node, from what was acknowledged before."""
    import os
    import signal

    from tests._procs import wait_stopped

    db = str(tmp_path / "bb.sqlite")
    port = free_port()
    node = start_node(namespace="rc2", port=port, db=db, types=TYPES)
    node2 = None
    try:
        async with BlackboardClient(node.client_net(), source="reader", timeout=30.0) as bb:
            kept = await bb.post(Segment(index=3), stamp=0.0)
            os.kill(node.proc.pid, signal.SIGSTOP)
            wait_stopped(node.proc.pid)
            asked = asyncio.ensure_future(bb.retrieve(Spec(type="bbt_segment")))
            stepped = asyncio.Event()
            asyncio.get_running_loop().call_soon(stepped.set)  # runs after the retrieve's first step
            await stepped.wait()
            assert bb.awaiting_acks  # the read is on the wire, unanswered
            node.kill()
            await bb.wait_node(alive=False, timeout=30)
            assert not asked.done()
            node2 = start_node(namespace="rc2", port=port, db=db, types=TYPES)
            got = await asyncio.wait_for(asked, 30)  # well before the 30 s timeout's retry
            assert [t.id for t in got] == [kept.id]
    finally:
        node.kill()
        if node2 is not None:
            node2.stop()
