"""Channel counts: the verdict that nothing between participants is in flight, and the process's own counting."""

from __future__ import annotations

from wire.channel_counts import ChannelCounts, Registry, SubCounts, settle
from wire.session import key_includes as includes


def proc(pid: str, puts: dict[str, int] | None = None, *subs: tuple[int, str, dict[str, int]]) -> ChannelCounts:
    return ChannelCounts(pid, puts or {}, tuple(SubCounts(sid, expr, d) for sid, expr, d in subs))


BASE = (proc("p1", {"ns/sim/clock": 10}, (1, "ns/sim/cmd", {"ns/sim/cmd": 7})),
        proc("p2", {"ns/sim/cmd": 7, "ns/eddie/inbox/nav": 3}, (1, "ns/sim/clock", {"ns/sim/clock": 10})),
        proc("p3", {}, (1, "ns/eddie/inbox/*", {"ns/eddie/inbox/nav": 3}), (2, "ns/sim/clock", {"ns/sim/clock": 10})))


def test_every_put_delivered_through_every_subscription_that_includes_its_key_is_quiet() -> None:
    now = (proc("p1", {"ns/sim/clock": 11}, (1, "ns/sim/cmd", {"ns/sim/cmd": 8})),
           proc("p2", {"ns/sim/cmd": 8, "ns/eddie/inbox/nav": 5}, (1, "ns/sim/clock", {"ns/sim/clock": 11})),
           proc("p3", {}, (1, "ns/eddie/inbox/*", {"ns/eddie/inbox/nav": 5}), (2, "ns/sim/clock", {"ns/sim/clock": 11})))
    v = settle(now, BASE, includes)
    assert v.quiet and v.short == frozenset() and v.excess == ()


def test_a_put_its_receiver_has_not_counted_yet_makes_that_receiver_short() -> None:
    now = (proc("p1", {"ns/sim/clock": 11}, (1, "ns/sim/cmd", {"ns/sim/cmd": 8})),
           proc("p2", {"ns/sim/cmd": 8, "ns/eddie/inbox/nav": 4}, (1, "ns/sim/clock", {"ns/sim/clock": 11})),
           proc("p3", {}, (1, "ns/eddie/inbox/*", {"ns/eddie/inbox/nav": 3}), (2, "ns/sim/clock", {"ns/sim/clock": 11})))
    v = settle(now, BASE, includes)
    assert not v.quiet and v.short == frozenset({"p3"}) and v.excess == ()


def test_a_put_counted_by_one_of_two_subscriptions_that_include_its_key_is_still_on_its_way() -> None:
    # process 3 listens to the clock twice (two subscriptions): each delivery is its own channel
    base = BASE[:2] + (proc("p3", {}, (2, "ns/sim/clock", {"ns/sim/clock": 10}), (3, "ns/sim/*", {"ns/sim/clock": 10})),)
    now = (proc("p1", {"ns/sim/clock": 11}, (1, "ns/sim/cmd", {"ns/sim/cmd": 7})),
           proc("p2", {"ns/sim/cmd": 7, "ns/eddie/inbox/nav": 3}, (1, "ns/sim/clock", {"ns/sim/clock": 11})),
           proc("p3", {}, (2, "ns/sim/clock", {"ns/sim/clock": 11}), (3, "ns/sim/*", {"ns/sim/clock": 10})))
    assert settle(now, base, includes).short == frozenset({"p3"})


def test_one_message_missing_and_another_extra_on_different_channels_do_not_cancel() -> None:
    # totals balance (what two waves of totals could not tell apart from quiet); channels do not
    now = (proc("p1", {"ns/sim/clock": 10}, (1, "ns/sim/cmd", {"ns/sim/cmd": 8})),
           proc("p2", {"ns/sim/cmd": 7, "ns/eddie/inbox/nav": 4}, (1, "ns/sim/clock", {"ns/sim/clock": 10})),
           proc("p3", {}, (1, "ns/eddie/inbox/*", {"ns/eddie/inbox/nav": 3}), (2, "ns/sim/clock", {"ns/sim/clock": 10})))
    v = settle(now, BASE, includes)
    assert v.short == frozenset({"p3"}) and len(v.excess) == 1 and "ns/sim/cmd" in v.excess[0]


def test_a_delivery_nobody_counted_as_put_cannot_be_judged() -> None:
    # a put from outside the barrier (a person's tool): counts cannot say whether anything is still on its way
    now = BASE[:2] + (proc("p3", {}, (1, "ns/eddie/inbox/*", {"ns/eddie/inbox/nav": 3, "ns/eddie/inbox/x": 1}),
                           (2, "ns/sim/clock", {"ns/sim/clock": 10})),)
    v = settle(now, BASE, includes)
    assert not v.quiet and v.excess and "ns/eddie/inbox/x" in v.excess[0]


def test_a_process_or_subscription_new_since_the_base_counts_from_zero() -> None:
    now = (*BASE[:2], proc("p3", {}, (1, "ns/eddie/inbox/*", {"ns/eddie/inbox/nav": 3}), (2, "ns/sim/clock", {"ns/sim/clock": 10}),
                           (4, "ns/x/**", {"ns/x/y": 2})),
           proc("p4", {"ns/x/y": 2}))
    assert settle(now, BASE, includes).quiet


def test_the_registry_counts_puts_and_deliveries_but_not_the_barriers_keys() -> None:
    r = Registry("/@lockstep/")
    sub = r.open("ns/eddie/inbox/*")
    assert r.open("ns/@lockstep/ask") is None
    r.put("ns/eddie/inbox/nav")
    r.put("ns/eddie/inbox/nav")
    r.put("ns/@lockstep/report/a-1")
    r.delivered(sub, "ns/eddie/inbox/nav")
    snap = r.snapshot()
    assert snap.puts == {"ns/eddie/inbox/nav": 2}
    assert [(s.expr, dict(s.delivered)) for s in snap.subs] == [("ns/eddie/inbox/*", {"ns/eddie/inbox/nav": 1})]
    r.close(sub)
    assert r.snapshot().subs == ()


def _child_proc(q) -> None:
    from wire.channel_counts import registry
    q.put(registry.proc)


def test_a_process_is_known_by_its_pid_and_a_token_drawn_again_in_a_forked_child() -> None:
    import multiprocessing
    import os

    from wire.channel_counts import registry

    mine = registry.proc
    assert mine == registry.proc and mine.startswith(f"{os.getpid()}-")
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_child_proc, args=(q,))
    p.start()
    theirs = q.get(timeout=30)
    p.join(30)
    assert theirs != mine and theirs.startswith(f"{p.pid}-")
