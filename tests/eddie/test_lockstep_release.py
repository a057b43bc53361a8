"""Lock-step: a module handles a message at the first tick after the sim time it was sent at, whenever it arrives.

A trigger the map manager sends on tick t may reach the controller before tick t itself does, or
after; before this rule the controller handled it at t in one run and at the next tick in another
(a lock-step EDDIE run that did not repeat: `set_speed` at 2.80 s against 2.85 s). Real Zenoh on
loopback; the module's own session sends, so the order of arrival is the order of the puts.
"""

from __future__ import annotations

import asyncio
import os

import msgpack
import pytest

from eddie.toolkit import Message, Module, message_type
from eddie.toolkit.message import encode_body, encode_envelope
from eddie.toolkit.module import _STAMP
from tests.eddie._net import net_pair
from wire.timemode import LOCKSTEP_ENV


@message_type("test.lockstep_note")
class Note(Message):
    """A numbered note."""

    n: int


async def test_a_message_is_released_at_the_tick_after_the_one_it_was_sent_in(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(LOCKSTEP_ENV, "1")
    listen, _connect, _ = net_pair(f"lsr{os.getpid()}")
    m = await Module("alpha", listen).__aenter__()
    try:
        link = m._link
        seen: list[tuple[float | None, int]] = []
        m.subscribe("beta", "notes", Note, lambda note: seen.append((m.now(), note.n)))

        async def tick(t: float) -> None:
            link.put(m.module_keys.sim_clock, msgpack.packb({"stamp": t}))
            await asyncio.wait_for(m.clock.wait_until(t), 10.0)

        def from_beta(n: int, sent_at: float) -> None:
            link.put(m.keys.inbox("alpha"), encode_envelope("beta", Note(n=n), sent_at))
            link.put(m.keys.topic("beta", "notes"), encode_body(Note(n=n)), attachment=_STAMP.pack(sent_at))

        await tick(1.0)
        from_beta(1, 1.0)  # sent on tick 1.0, arrives after it
        from_beta(2, 1.05)  # sent on tick 1.05 by a sender that heard it first: arrives before it here
        await tick(1.05)
        assert seen == [(1.05, 1)]
        assert m.pending() == 1 and (await m.receive(timeout=1.0)).message == Note(n=1)
        await tick(1.1)
        assert seen == [(1.05, 1), (1.1, 2)]
        assert m.pending() == 1 and (await m.receive(timeout=1.0)).message == Note(n=2)

        # a module publishing what an input newer than its clock gave (the controller's state from odometry
        # of the coming step) stamps it with that input's time: released after it, not after the clock
        own: list[tuple[float | None, int]] = []
        m.subscribe("alpha", "state", Note, lambda note: own.append((m.now(), note.n)))
        m.publish("state", Note(n=3), stamp=1.15)  # heard before tick 1.15
        m.publish("state", Note(n=4))  # stamped with the clock: 1.1
        await tick(1.15)
        assert own == [(1.15, 4)]
        await tick(1.2)
        assert own == [(1.15, 4), (1.2, 3)]
    finally:
        await m.close()
