"""Every process counts its Zenoh traffic and reports it, with CPU and memory, in its heartbeat."""

from __future__ import annotations

import threading

from tests.modules._net import net_pair
from wire.health import Heartbeat, decode_heartbeat, encode_heartbeat, process_usage
from wire.keys import LockstepKeys
from wire.session import barrier_traffic, open_session, traffic


def test_traffic_counts_puts_and_received_samples_with_their_bytes() -> None:
    listener, connector, _ = net_pair("usage")
    a = open_session(listener)
    b = open_session(connector)
    try:
        b.wait_connected(timeout=10.0)
        got = threading.Event()
        seen: list[int] = []

        def on_sample(_key: str, data: bytes) -> None:
            seen.append(len(data))
            if len(seen) == 5:
                got.set()

        a.subscribe_payload("sidewalk/usage/t", on_sample)
        before = traffic()
        # the subscriber's declaration reaches b asynchronously: publish until the first sample arrives
        first = threading.Event()
        a.subscribe_payload("sidewalk/usage/probe", lambda *_: first.set())
        while not first.wait(0.05):
            b.put("sidewalk/usage/probe", b"?")
        mid = traffic()
        for n in (10, 20, 30, 40, 50):
            b.put("sidewalk/usage/t", b"x" * n)
        assert got.wait(10.0)
        after = traffic()
        # one process holds both sessions: it sent and received the same five payloads
        assert after[0] - mid[0] == 5 and after[1] - mid[1] == 150
        assert after[2] - mid[2] >= 5 and after[3] - mid[3] >= 150
        assert mid[0] > before[0]
    finally:
        b.close()
        a.close()


def test_the_lockstep_barriers_traffic_is_counted_apart() -> None:
    listener, connector, _ = net_pair("usageb")
    a = open_session(listener)
    b = open_session(connector)
    try:
        b.wait_connected(timeout=10.0)
        ask = LockstepKeys("usageb").report("pilot")  # a key of the barrier's, as a participant answers the simulator
        got, other = threading.Event(), threading.Event()
        a.subscribe_payload(ask, lambda *_: got.set())
        a.subscribe_payload("sidewalk/usageb/pilot/path", lambda *_: other.set())
        while not other.wait(0.05):
            b.put("sidewalk/usageb/pilot/path", b"p" * 7)
        b0, t0 = barrier_traffic(), traffic()
        b.put("sidewalk/usageb/pilot/path", b"p" * 7)
        assert barrier_traffic() == b0 and traffic()[0] == t0[0] + 1  # a module's message: not the barrier's
        while not got.wait(0.05):
            b.put(ask, b"a" * 11)
        b1 = barrier_traffic()
        assert b1[0] > b0[0] and b1[1] - b0[1] == 11 * (b1[0] - b0[0])  # every ask sent, with its bytes
        assert b1[2] >= b0[2] + 1 and b1[3] >= b0[3] + 11  # and received by the other session
        u = process_usage(traffic(), barrier_traffic())
        assert u.barrier_msgs_out == b1[0] and u.msgs_out >= u.barrier_msgs_out
    finally:
        b.close()
        a.close()


def test_heartbeat_carries_usage_round_trip() -> None:
    u = process_usage((3, 300, 4, 400))
    assert u.cpu_s > 0.0 and u.rss_bytes > 10_000_000  # a Python with numpy and zenoh loaded
    hb = Heartbeat(module="pilot", seq=1, wall_time=1.0, period_s=1.0, pid=1, usage=u)
    back = decode_heartbeat(encode_heartbeat(hb))
    assert back.usage == u and back.usage.bytes_in == 400
