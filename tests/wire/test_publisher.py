"""A batched (not express) publisher on real Zenoh sessions over loopback: a burst arrives whole and in order."""

from __future__ import annotations

import threading

import pytest

from tests.modules._net import net_pair
from wire.session import open_session


@pytest.mark.parametrize("express", [True, False])
def test_a_burst_arrives_whole_and_in_order(express: bool) -> None:
    listener, connector, _ = net_pair(f"pub{int(express)}")
    a = open_session(listener)
    b = open_session(connector)
    try:
        b.wait_connected(timeout=10.0)
        n = 3000
        seen: list[int] = []
        done = threading.Event()

        def on_sample(_key: str, data: bytes) -> None:
            seen.append(int(data))
            if len(seen) == n:
                done.set()

        first = threading.Event()
        a.subscribe_payload("sidewalk/pub/probe", lambda *_: first.set())
        a.subscribe_payload("sidewalk/pub/t", on_sample)
        probe = b.publisher("sidewalk/pub/probe")
        while not first.wait(0.05):  # the subscriptions reach b asynchronously
            probe.put(b"?")
        pub = b.publisher("sidewalk/pub/t", express=express)
        for i in range(n):
            pub.put(str(i).encode())
        assert done.wait(20.0), f"{len(seen)} of {n} samples arrived"
        assert seen == list(range(n))
    finally:
        b.close()
        a.close()
