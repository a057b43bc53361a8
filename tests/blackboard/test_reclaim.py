"""Monitors of a client that never declared liveliness are reclaimed by the node (nobody else would drop them);
a client that did declare it keeps its monitors."""

import asyncio
import time

import msgpack
import pytest

from blackboard import BlackboardClient, Spec
from tests.blackboard.test_bad_input import Raw

pytestmark = pytest.mark.timeout(120)


async def test_monitors_of_a_client_without_liveliness_are_reclaimed(node):
    raw = Raw(node)
    bb = await BlackboardClient.connect(node.client_net(), source="kept")
    try:
        async with bb.monitor(Spec(type="bbt_landmark")):
            base = (await bb.stats()).monitors
            for i in range(3):  # a tool that registers monitors but never says it is alive
                ok, reply = raw.get(raw.keys.monitor, msgpack.packb(
                    {"client": "ghost-client", "mid": f"m{i}", "spec": {"type": "bbt_landmark"}}))
                assert ok, reply
            assert (await bb.stats()).monitors == base + 3
            t0 = time.monotonic()
            while (await bb.stats()).monitors > base and time.monotonic() - t0 < 40:
                await asyncio.sleep(0.5)  # polling the node's counters: reclaiming has no event a client sees
            assert (await bb.stats()).monitors == base, "the ghost client's monitors were never reclaimed"
            assert time.monotonic() - t0 >= 10.0  # not at once: a slow client gets time to declare itself
    finally:
        await bb.close()
        raw.s.close()
