"""Durability: SIGKILL the node while a client streams posts; every acknowledged token is there after restart."""

from __future__ import annotations

import asyncio

import pytest

from blackboard import BlackboardClient, BlackboardError, NodeUnavailableError, Spec
from blackboard.testing import start_node
from wire.ports import free_port
from tests.blackboard.sample_types import Segment

pytestmark = pytest.mark.timeout(90)


@pytest.mark.parametrize("sync", ["normal", "full"])
async def test_sigkill_while_streaming_loses_no_acknowledged_token(tmp_path, sync):
    db = str(tmp_path / "bb.sqlite")
    port = free_port()
    node = start_node(namespace="dur", port=port, db=db, sync=sync, types=("tests.blackboard.sample_types",))
    acked: set[str] = set()
    enough = asyncio.Event()
    stop = False
    failures = 0
    try:
        async with BlackboardClient(node.client_net(), source="streamer", timeout=3.0) as bb:

            def record(fut: asyncio.Future) -> None:
                nonlocal failures
                if fut.cancelled() or fut.exception() is not None:
                    failures += 1
                    return
                acked.add(fut.result().id)
                if len(acked) >= 400:
                    enough.set()

            async def stream() -> None:
                i = 0
                while not stop:
                    futs = [asyncio.ensure_future(bb.post(Segment(index=i + k), stamp=float(i + k))) for k in range(25)]
                    for f in futs:
                        f.add_done_callback(record)
                    i += 25
                    await asyncio.gather(*futs, return_exceptions=True)

            streamer = asyncio.create_task(stream())
            await asyncio.wait_for(enough.wait(), 60)
            # posts queued now are on their way (the first is sent at once) when the node dies
            extra = [bb.post(Segment(index=-2 - k), stamp=0.0) for k in range(25)]
            for f in extra:
                f.add_done_callback(record)
            node.kill()  # SIGKILL with posts in flight
            stop = True
            await asyncio.wait_for(streamer, 30)
            outcomes = await asyncio.wait_for(asyncio.gather(*extra, return_exceptions=True), 30)
            assert all(isinstance(o, NodeUnavailableError) or o.id in acked for o in outcomes)
        assert failures > 0  # posts were in flight when the node died, and failed rather than hang
    finally:
        node.kill()

    node2 = start_node(namespace="dur", port=port, db=db, sync=sync, types=("tests.blackboard.sample_types",))
    try:
        async with BlackboardClient(node2.client_net(), source="checker") as bb:
            stored = {t["id"] for t in await bb.retrieve_raw(Spec(type="bbt_segment"))}
            missing = acked - stored
            assert not missing, f"{len(missing)} acknowledged tokens lost, e.g. {sorted(missing)[:5]}"
            assert len(stored) >= len(acked) >= 400
            # the node keeps working on the recovered store, and ids are not reused
            t = await bb.post(Segment(index=-1), stamp=0.0)
            assert t.id not in stored
    except BlackboardError:
        raise
    finally:
        node2.stop()
