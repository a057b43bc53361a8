"""The toolkit's links on real Zenoh sessions over loopback: send/receive, request/reply, time-outs, bad payloads."""

from __future__ import annotations

import asyncio
import os

import msgpack
import pytest

from eddie.errors import BadMessage, LinkTimeout, NoSuchModule, ServiceError, UnknownMessageType
from eddie.toolkit import Incoming, Message, Module, message_type
from tests.eddie._net import net_pair


@message_type("test.ping")
class Ping(Message):
    """A test message: a number and a text."""

    n: int
    text: str = ""


@message_type("test.pong")
class Pong(Message):
    """A test reply: the number doubled."""

    n2: int


async def _pair(tag: str) -> tuple[Module, Module]:
    listen, connect, _ = net_pair(f"tk{tag}{os.getpid()}")
    a = await Module("alpha", listen).__aenter__()
    b = await Module("beta", connect).__aenter__()
    await b.wait_connected(10.0)
    return a, b


async def _sync(a: Module, b: Module) -> None:
    """Wait until a's inbox is reachable from b (the subscription has propagated)."""
    while True:
        await b.send("alpha", Ping(n=-1))
        try:
            got = await a.receive(timeout=0.2)
        except LinkTimeout:
            continue
        assert got.message == Ping(n=-1)
        while a.pending():
            await a.receive(0)
        return


async def test_send_and_receive_typed_messages_in_order():
    a, b = await _pair("s")
    try:
        await _sync(a, b)
        for i in range(20):
            await b.send("alpha", Ping(n=i, text=f"m{i}"))
        got = [await a.receive(timeout=5.0) for _ in range(20)]
        assert [g.message.n for g in got] == list(range(20))
        assert all(isinstance(g.message, Ping) and g.sender == "beta" for g in got)
        with pytest.raises(LinkTimeout, match="alpha"):
            await a.receive(timeout=0.05)
    finally:
        await b.close()
        await a.close()


async def test_request_returns_the_typed_reply_and_errors_are_named():
    a, b = await _pair("r")
    try:
        async def double(inc: Incoming) -> Message:
            assert isinstance(inc.message, Ping)
            if inc.message.n < 0:
                raise ValueError("negative")
            return Pong(n2=2 * inc.message.n)

        a.serve("double", double)
        while True:  # the queryable propagates to b's session
            try:
                reply = await b.request("alpha", "double", Ping(n=21), timeout=1.0, reply_type=Pong)
                break
            except NoSuchModule:
                await asyncio.sleep(0.05)
        assert reply == Pong(n2=42)
        with pytest.raises(ServiceError, match="negative"):
            await b.request("alpha", "double", Ping(n=-3))
        with pytest.raises(NoSuchModule, match="gamma/double"):
            await b.request("gamma", "double", Ping(n=1), timeout=1.0)
    finally:
        await b.close()
        await a.close()


async def test_request_to_a_slow_service_times_out_naming_it():
    a, b = await _pair("t")
    try:
        release = asyncio.Event()

        async def slow(inc: Incoming) -> Message:
            await release.wait()
            return Pong(n2=0)

        async def fast(inc: Incoming) -> Message:
            return Pong(n2=1)

        a.serve("slow", slow)
        a.serve("fast", fast)
        while True:
            try:
                await b.request("alpha", "fast", Ping(n=1), timeout=1.0)
                break
            except NoSuchModule:
                await asyncio.sleep(0.05)
        with pytest.raises(LinkTimeout, match="alpha/slow"):
            await b.request("alpha", "slow", Ping(n=1), timeout=0.3)
        release.set()
    finally:
        await b.close()
        await a.close()


async def test_a_bad_payload_names_sender_and_field_and_the_inbox_goes_on():
    a, b = await _pair("b")
    try:
        await _sync(a, b)
        key = b.keys.inbox("alpha")
        b.link.put(key, msgpack.packb({"sender": "beta", "type": "test.ping", "stamp": None, "body": {"n": "many"}}))
        b.link.put(key, msgpack.packb({"sender": "beta", "type": "test.nothing", "stamp": None, "body": {}}))
        b.link.put(key, b"\xc1garbage")
        b.link.put(key, b'{"sender": "jsonsender", "type": "test.ping", "stamp": 1.5, "body": {"n": 7}}', as_json=True)
        with pytest.raises(BadMessage) as e1:
            await a.receive(timeout=5.0)
        assert e1.value.sender == "beta" and e1.value.field == "n" and "beta" in str(e1.value) and "n" in str(e1.value)
        with pytest.raises(UnknownMessageType, match="test.nothing"):
            await a.receive(timeout=5.0)
        with pytest.raises(BadMessage, match="neither msgpack nor JSON"):
            await a.receive(timeout=5.0)
        got = await a.receive(timeout=5.0)
        assert got.sender == "jsonsender" and got.stamp == 1.5 and got.message == Ping(n=7)
    finally:
        await b.close()
        await a.close()


async def test_streams_push_bare_fields_to_subscribers():
    a, b = await _pair("p")
    try:
        seen: list[Ping] = []
        got = asyncio.Event()

        def on(msg: Ping) -> None:
            seen.append(msg)
            if msg.n == 99:
                got.set()

        b.subscribe("alpha", "pings", Ping, on)
        async def pump() -> None:
            i = 0
            while not got.is_set():
                a.publish("pings", Ping(n=99 if i > 0 and seen else i))
                i += 1
                await asyncio.sleep(0.02)

        await asyncio.wait_for(pump(), 10.0)
        raw = msgpack.unpackb(__import__("eddie.toolkit.message", fromlist=["x"]).encode_body(Ping(n=1)))
        assert raw == {"n": 1, "text": ""}  # what the NAVIGATION MONITOR reads: bare fields
    finally:
        await b.close()
        await a.close()
