"""Per-role key limits: every role × key family × operation through a secure router, against the rules file.

A real router (`sidewalk up router --secure DIR`) enforces the default rules; one session per role
connects with that role's certificate and password. A `probe` role (added to this test's copy of
the rules, granted everything) is the other end of each exchange:

- write: each role puts on one key of every family; the probe hears only what the rules grant;
- read:  each role subscribes to one key of every family; the probe puts on all of them;
- ask:   the probe serves one key of every family; each role queries all of them;
- serve: each role serves one key of every family; the probe queries all of them.

A role may use a key when a family granted to it for that operation includes the key (its own
grant or `everyone`'s) — the meaning docs/security.md gives the file. The few guarantees the issue
names (who drives, who reads truth, who submits missions) are asserted by name besides.
"""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import pytest
import yaml

from sidewalk.security import init_secure_dir, load_rules
from sidewalk.security.rules import OPERATIONS, Rules
from tests.modules._procs import spawn, stop
from wire.keys import root
from wire.network import NetworkConfig, SecureConfig
from wire.ports import free_port
from wire.session import Session, open_session

pytestmark = pytest.mark.e2e

NS = "aclmatrix"
PROBE = "probe"
WAIT = 20.0  # wall [s] for a synchronisation that must happen
QUERY_TIMEOUT = 3.0  # wall [s] a denied query waits before it ends with no reply


def _concrete(pattern: str) -> str:
    """Return one key `pattern` includes (wildcard chunks become `x`)."""
    return "/".join("x" if c in ("*", "**") else c for c in pattern.split("/"))


def _includes(pattern: str, key: str) -> bool:
    """Return whether key expression `pattern` (chunks, `*`, `**`) includes the concrete `key`.

    As in Zenoh, a wildcard never matches a verbatim chunk (one starting with `@`, e.g. the barrier's `@lockstep`).
    """
    p, k = pattern.split("/"), key.split("/")

    def match(i: int, j: int) -> bool:
        if i == len(p):
            return j == len(k)
        if p[i] == "**":
            return any(match(i + 1, jj) for jj in range(j, len(k) + 1) if not any(c.startswith("@") for c in k[j:jj]))
        return j < len(k) and (p[i] == k[j] or (p[i] == "*" and not k[j].startswith("@"))) and match(i + 1, j + 1)

    return match(0, 0)


def _allowed(rules: Rules, role: str, op: str, key: str) -> bool:
    """Return whether the rules let `role` `op` the concrete `key` (relative to the namespace root)."""
    return any(_includes(p, key) for f in rules.granted(role, op) for p in rules.families[f].keys_for(role))


@pytest.fixture(scope="module")
def deployment(tmp_path_factory):
    d = tmp_path_factory.mktemp("acl") / "sec"
    init_secure_dir(d, extra_roles=(PROBE,))
    data = yaml.safe_load((d / "rules.yaml").read_text())
    # `everything` (`**`) matches no verbatim chunk: the probe also needs the barrier's keys to see them used
    data["families"]["verbatim"] = {"doc": "the barrier's keys, for the probe", "keys": ["@lockstep/**"]}
    data["roles"][PROBE] = {op: ["everything", "verbatim"] for op in OPERATIONS}
    data["extra_roles"] = []
    (d / "rules.yaml").write_text(yaml.safe_dump(data))
    rules = load_rules(d / "rules.yaml")
    ep = f"tcp/127.0.0.1:{free_port()}"
    router = spawn([sys.executable, "-m", "sidewalk", "up", "router", "--ns", NS, "--listen", ep, "--secure", str(d)],
                   "router ready")
    sessions: dict[str, Session] = {}
    try:
        for role in rules.all_roles:
            s = open_session(NetworkConfig(namespace=NS, connect=(ep,), secure=SecureConfig(dir=d, role=role)))
            s.wait_connected(timeout=10, name=role)
            sessions[role] = s
        yield rules, sessions
    finally:
        for s in sessions.values():
            s.close()
        stop(router)


def _targets(rules: Rules) -> dict[str, dict[str, str]]:
    """Return, per role, one concrete key (relative) of every family, `{role}` taken as that role."""
    return {role: {f: _concrete(fam.keys_for(role)[0]) for f, fam in rules.families.items()} for role in rules.all_roles}


class _Gate:
    """Count arrivals of named sentinels; `wait` until every expected one came."""

    def __init__(self, expected: set[str]) -> None:
        self.expected, self.seen, self.cv = set(expected), set(), threading.Condition()

    def hit(self, name: str) -> None:
        with self.cv:
            self.seen.add(name)
            self.cv.notify_all()

    def wait(self, what: str) -> None:
        with self.cv:
            ok = self.cv.wait_for(lambda: self.expected <= self.seen, WAIT)
        assert ok, f"{what}: no sentinel from {sorted(self.expected - self.seen)}"


def _expected(rules: Rules, targets: dict[str, dict[str, str]], op: str) -> set[tuple[str, str]]:
    return {(role, f) for role, fams in targets.items() if role != PROBE for f, key in fams.items()
            if _allowed(rules, role, op, key)}


def _roles(rules: Rules) -> list[str]:
    return [r for r in rules.all_roles if r != PROBE]


def test_every_role_uses_only_the_key_families_the_rules_grant(deployment) -> None:
    rules, sessions = deployment
    base = root(NS) + "/"
    targets = _targets(rules)
    probe = sessions[PROBE]
    roles = _roles(rules)
    seen: dict[str, set[tuple[str, str]]] = {op: set() for op in OPERATIONS}
    lock = threading.Lock()

    def note(op: str, role: str, fam: str) -> None:
        with lock:
            seen[op].add((role, fam))

    # ---- write: each role puts on every family's key, then a heartbeat sentinel (same link, in order)
    gate = _Gate(set(roles))
    keys_written = {base + k for fams in targets.values() for k in fams.values()}
    heard = [probe.subscribe(key, lambda s: note("write", *s.payload.decode().split("|", 1))) for key in keys_written]
    probe.subscribe(base + "heartbeat/sentinel-w/*", lambda s: gate.hit(s.key.rsplit("/", 1)[1]))
    # the probe's subscriptions reach each role through the router before that role's first put
    ready = _Gate(set(roles))
    for role in roles:
        sessions[role].subscribe(base + "heartbeat/go-w", lambda _s, r=role: ready.hit(r))
    while not ready.expected <= ready.seen:
        probe.put(base + "heartbeat/go-w", b"go")
        with ready.cv:
            ready.cv.wait(0.05)
    for role in roles:
        s = sessions[role]
        for fam, key in targets[role].items():
            s.put(base + key, f"{role}|{fam}".encode())
        s.put(base + f"heartbeat/sentinel-w/{role}", b"done")
    gate.wait("write")
    for h in heard:
        probe.undeclare(h)

    # ---- read: each role subscribes to every family's key; the probe puts on all of them, then a sentinel
    gate, ready = _Gate(set(roles)), _Gate(set(roles))
    for role in roles:
        s = sessions[role]
        for fam, key in targets[role].items():
            s.subscribe(base + key, lambda _s, r=role, f=fam: note("read", r, f))
        s.subscribe(base + "heartbeat/sentinel-r", lambda _s, r=role: gate.hit(r))
        s.put(base + f"heartbeat/ready-r/{role}", b"subscribed")  # after its subscriptions, on the same link
    probe.subscribe(base + "heartbeat/ready-r/*", lambda s: ready.hit(s.key.rsplit("/", 1)[1]))
    # a role may have said "subscribed" before the probe listened: ask again until every one was heard
    while not ready.expected <= ready.seen:
        for role in sorted(ready.expected - ready.seen):
            sessions[role].put(base + f"heartbeat/ready-r/{role}", b"subscribed")
        with ready.cv:
            ready.cv.wait(0.05)
    for key in sorted({k for fams in targets.values() for k in fams.values()}):
        probe.put(base + key, b"sample")
    probe.put(base + "heartbeat/sentinel-r", b"done")
    gate.wait("read")

    # ---- ask: the probe serves every family's key; each role queries all of them
    def serve_probe(q) -> None:
        q.reply(b"probe")
        q.finish()

    served = [probe.queryable(base + key, serve_probe) for key in sorted({k for fams in targets.values() for k in fams.values()})]
    ready = _Gate(set(roles))
    for role in roles:
        sessions[role].subscribe(base + "heartbeat/served-a", lambda _s, r=role: ready.hit(r))
    while not ready.expected <= ready.seen:  # the queryables' declarations precede this put on the probe's link
        probe.put(base + "heartbeat/served-a", b"served")
        with ready.cv:
            ready.cv.wait(0.05)
    done = threading.Semaphore(0)
    n = 0
    for role in roles:
        for fam, key in targets[role].items():
            sessions[role].get(base + key, timeout=QUERY_TIMEOUT,
                               on_reply=lambda r, ro=role, f=fam: r.ok and note("ask", ro, f), on_done=done.release)
            n += 1
    for _ in range(n):
        assert done.acquire(timeout=QUERY_TIMEOUT + WAIT), "a query never ended"
    for h in served:
        probe.undeclare(h)

    # ---- serve: each role serves every family's key; the probe queries all of them
    def server(role: str):
        def answer(q) -> None:
            q.reply(role.encode())
            q.finish()
        return answer

    ready = _Gate(set(roles))
    probe.subscribe(base + "heartbeat/ready-s/*", lambda s: ready.hit(s.key.rsplit("/", 1)[1]))
    for role in roles:  # not complete: a query goes to every server, not the best one
        for key in set(targets[role].values()):
            sessions[role].queryable(base + key, server(role), complete=False)
    while not ready.expected <= ready.seen:  # the declarations precede this put on the role's link
        for role in sorted(ready.expected - ready.seen):
            sessions[role].put(base + f"heartbeat/ready-s/{role}", b"serving")
        with ready.cv:
            ready.cv.wait(0.05)
    by_key: dict[str, list[tuple[str, str]]] = {}
    for role in roles:
        for fam, key in targets[role].items():
            by_key.setdefault(key, []).append((role, fam))
    n = 0
    for key, pairs in by_key.items():
        def on_reply(r, pairs=pairs) -> None:
            if r.ok:
                who = r.payload.decode()
                for role, fam in pairs:
                    if role == who:
                        note("serve", role, fam)
        probe.get(base + key, timeout=QUERY_TIMEOUT, on_reply=on_reply, on_done=done.release)
        n += 1
    for _ in range(n):
        assert done.acquire(timeout=QUERY_TIMEOUT + WAIT), "a query never ended"

    # ---- every role × family × operation as the rules file says
    for op in OPERATIONS:
        want = _expected(rules, targets, op)
        got = seen[op]
        assert got == want, (f"{op}: allowed but not granted {sorted(got - want)}; "
                             f"granted but denied {sorted(want - got)}")

    # ---- the guarantees of issue 14, by name
    def who(op: str, fam: str) -> set[str]:
        return {r for r, f in seen[op] if f == fam}

    assert who("write", "drive") == {"helm", "controller"}
    assert who("read", "truth") == {"monitor", "recorder", "evaluation"}
    assert who("ask", "truth") == {"monitor", "recorder", "evaluation"}
    assert who("ask", "missions") == {"operator"}
    assert who("serve", "missions") == {"captain", "mission_service"}
    assert who("write", "clock") == {"sim"} and who("serve", "sensors") == {"sim"}
    assert who("serve", "bb-services") == {"blackboard"} and who("write", "bb-replies") == {"blackboard"}
    assert who("write", "controller-inbox") == {"map_manager", "mission_service", "road_following", "obstacle_stop"}
    assert who("write", "navigator-inbox") == {"map_manager", "landmark_matching", "road_following"}
    # every role may say it is alive and hear the others, and nothing else unless granted
    assert who("write", "health") == set(roles) and who("read", "health") == set(roles)
    assert len(seen["write"]) < len(roles) * len(rules.families) / 4
