"""Fuzz every endpoint of a live system: generated payloads to every queryable and every subscribed key.

Real processes on loopback Zenoh: a router, the blackboard node, the simulator, the CAPTAIN, and
EDDIE's integrated controller, navigator and annotated map manager. Each key gets `payloads`
generated payloads (seeded numpy Generator): random bytes, truncated msgpack and JSON, well-formed
messages of the wrong types and shapes, and a few huge ones (2 MB; the CAPTAIN's submit also 10 MB).

The sim clock (`sim/clock`) is left out: any number on it is a valid tick, and a forged tick far
ahead makes the controller and the navigator stop answering for long (they catch up to the forged
time); under `--secure` only the simulator may publish it. That is a trust boundary, not bad input.

A query must be answered with a valid reply or a *typed* error — a msgpack or JSON object with a
string `error` — of at most `MAX_REPLY_BYTES` (never an echo of a huge payload; a valid request,
such as an empty capture request, may get a large valid reply); a query nobody
answers counts as ignored. A put to a subscribed key can only be ignored. Afterwards every process
must still be alive and answer a valid request: that reply, sent after the last garbage on the same
links, is also what says the garbage was taken (no pause). Figures: payloads, answered, typed errors, ignored,
violations (the first few, each with the key and the kind of payload), the largest reply [bytes],
and per process whether it still serves.
"""

from __future__ import annotations

import asyncio
import json
import tempfile
import time
from pathlib import Path

import msgpack
import numpy as np

from sidewalk.supervisor import ProcessPlan, Supervisor
from wire.aio import Link
from wire.keys import BlackboardKeys, EddieKeys, ModuleKeys, SimKeys
from wire.network import NetworkConfig
from wire.ports import free_port

__all__ = ["run", "generate_payloads", "PAYLOAD_KINDS", "MAX_REPLY_BYTES"]

#: The largest reply a garbage payload may get [bytes].
MAX_REPLY_BYTES = 64 * 1024

PAYLOAD_KINDS = ("random-bytes", "truncated-msgpack", "truncated-json", "wrong-types-msgpack", "wrong-types-json",
                 "empty", "huge")

#: Field names that the system's requests use, so generated objects reach the validators, not just the decoders.
_FIELDS = ("type", "op", "attrs", "spec", "id", "client", "mid", "mission_id", "reason", "where", "frame", "stamp",
           "geometry", "kind", "x", "y", "yaw", "speed", "curvature", "mode", "duration", "seq", "sender", "body", "t",
           "steps", "destination", "mission", "polygon", "limit", "cancel", "expected_version", "source", "points")


def _value(rng: np.random.Generator, depth: int = 0) -> object:
    """Return a random msgpack/JSON-able value (wrong types on purpose)."""
    k = int(rng.integers(0, 9 if depth < 3 else 6))
    if k == 0:
        return None
    if k == 1:
        return bool(rng.integers(0, 2))
    if k == 2:
        return int(rng.choice([0, -1, 1, 2**31, -(2**53), int(rng.integers(-1000, 1000))]))
    if k == 3:
        return float(rng.choice([0.0, -1.5, 1e308, -1e-308, float(rng.normal() * 1e3)]))
    if k == 4:
        return "".join(chr(int(c)) for c in rng.integers(32, 0x2FFF, size=int(rng.integers(0, 24))))
    if k == 5:
        return rng.choice(list(_FIELDS)).item()
    if k == 6:
        return [_value(rng, depth + 1) for _ in range(int(rng.integers(0, 5)))]
    return {str(rng.choice(list(_FIELDS))): _value(rng, depth + 1) for _ in range(int(rng.integers(0, 6)))}


def generate_payloads(rng: np.random.Generator, n: int, *, huge: tuple[int, ...] = (2 * 1024 * 1024,)) -> list[tuple[str, bytes]]:
    """Return `n` (kind, payload) pairs: the `huge` sizes first, then the other kinds in turn."""
    out: list[tuple[str, bytes]] = [("huge", rng.integers(0, 256, size=size, dtype=np.uint8).tobytes()) for size in huge[:n]]
    kinds = PAYLOAD_KINDS[:-1]
    for i in range(n - len(out)):
        kind = kinds[i % len(kinds)]
        if kind == "random-bytes":
            data = rng.integers(0, 256, size=int(rng.geometric(1 / 200)), dtype=np.uint8).tobytes()
        elif kind == "empty":
            data = b""
        else:
            obj = {str(rng.choice(list(_FIELDS))): _value(rng) for _ in range(int(rng.integers(1, 6)))}
            if rng.random() < 0.3:
                obj = _value(rng)  # not even an object
            data = msgpack.packb(obj) if "msgpack" in kind else json.dumps(obj).encode()
            if kind.startswith("truncated") and len(data) > 1:
                data = data[: int(rng.integers(1, len(data)))]
        out.append((kind, data))
    return out


def _typed_error(payload: bytes) -> bool:
    """Return whether an error reply is a msgpack or JSON object carrying a string `error`."""
    for decode in (lambda b: json.loads(b), lambda b: msgpack.unpackb(b, raw=False)):
        try:
            obj = decode(payload)
        except Exception:  # noqa: BLE001 - not this encoding
            continue
        return isinstance(obj, dict) and isinstance(obj.get("error"), str)
    return False


def _plans(out: Path, ns: str, endpoint: str) -> list[ProcessPlan]:
    """Return the processes under test: router, node, simulator, CAPTAIN, controller, navigator, map manager."""
    from sidewalk.eddie_run import compile_annotated_map
    from sidewalk.launcher import RunConfig, prepare_run

    setup = prepare_run(RunConfig(world="campus", mission="campus-tour", out=out, arch="eddie", perception=False))
    amap = compile_annotated_map(setup, out)
    z = ("--ns", ns, "--connect", endpoint)
    sx, sy, syaw = setup.start_belief
    return [
        ProcessPlan("router", ("-m", "sidewalk", "up", "router", "--ns", ns, "--listen", endpoint)),
        ProcessPlan("blackboard", ("-m", "sidewalk", "up", "blackboard", *z, "--db", str(out / "blackboard.db"),
                                   "--types", "modules.vocabulary")),
        ProcessPlan("sim", ("-m", "sidewalk", "up", "sim", "--world", "campus", "--vehicle", setup.vehicle, "--rtf", "5",
                            "--seed", "0", *z)),
        ProcessPlan("captain", ("-m", "sidewalk", "up", "captain", *z)),
        ProcessPlan("controller", ("-m", "sidewalk", "up", "controller", "--vehicle", setup.vehicle, *z)),
        ProcessPlan("navigator", ("-m", "sidewalk", "up", "navigator", f"--start-pose={sx},{sy},{syaw}", *z)),
        ProcessPlan("map_manager", ("-m", "sidewalk", "up", "map_manager", "--annotated-map", str(amap), *z)),
    ]


async def _still_serving(net: NetworkConfig, link: Link, why: dict[str, str]) -> dict[str, bool]:
    """Ask every process a valid request; return per process whether it answered it rightly (`why` gets each failure)."""
    from blackboard import BlackboardClient, Spec
    from eddie.messages.controller import Position, PositionQuery
    from eddie.messages.map_manager import AnnotationQuery
    from eddie.messages.navigator import WorldFromLocal, WorldFromLocalQuery
    from eddie.toolkit import Module
    from sidewalk.mission_client import MissionClient, MissionRejected
    from modules.vocabulary import MapPlaces

    ok: dict[str, bool] = {}
    try:
        bb = await BlackboardClient.connect(net, source="fuzz-check")
        try:
            await bb.post(MapPlaces(map_name="fuzz", places=("a",)), stamp=0.0)
            ok["blackboard"] = any(t.attrs.map_name == "fuzz" for t in await bb.retrieve(Spec(type="map_places")))
        finally:
            await bb.close()
    except Exception as exc:  # noqa: BLE001 - any failure is a process that does not serve
        ok["blackboard"], why["blackboard"] = False, f"{type(exc).__name__}: {exc}"
    replies = await link.get(SimKeys(net.namespace).info, timeout=10.0)
    ok["sim"] = bool(replies) and replies[0].ok
    try:
        await MissionClient(link, ModuleKeys(net.namespace), timeout=10.0).status("no-such-mission")
        ok["captain"] = False
    except MissionRejected as exc:
        ok["captain"] = exc.rejection.error == "unknown_mission"
    except Exception as exc:  # noqa: BLE001
        ok["captain"], why["captain"] = False, f"{type(exc).__name__}: {exc}"
    async with Module("fuzz_check", net) as m:
        for name, ask in (
            ("controller", lambda: m.request("controller", "position", PositionQuery(), reply_type=Position, timeout=10.0)),
            ("navigator", lambda: m.request("navigator", "world_from_local", WorldFromLocalQuery(), reply_type=WorldFromLocal, timeout=10.0)),
            ("map_manager", lambda: m.request("map_manager", "query", AnnotationQuery(), timeout=10.0)),
        ):
            try:
                await ask()
                ok[name] = True
            except Exception as exc:  # noqa: BLE001
                ok[name], why[name] = False, f"{type(exc).__name__}: {exc}"
    return ok


async def _fuzz(payloads: int, seed: int, work: Path) -> dict:
    ns = f"fuzz{free_port()}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    net = NetworkConfig(namespace=ns, connect=(endpoint,))
    sup = Supervisor(work / "logs")
    rng = np.random.default_rng(seed)
    res: dict = {"payloads_per_key": payloads, "seed": seed, "answered": 0, "typed_errors": 0, "ignored": 0,
                 "violations": [], "violation_count": 0, "max_reply_bytes": 0, "payloads": 0}
    try:
        for plan in _plans(work, ns, endpoint):
            await sup.start(plan, ready_timeout=120.0)
        link = Link.open(net)
        try:
            bk, sk, ek, mk = BlackboardKeys(ns), SimKeys(ns), EddieKeys(ns), ModuleKeys(ns)
            clients = [k.rsplit("/", 1)[-1] for k in await link.alive_keys(f"{bk.client_alive_prefix}/*", timeout=5.0)]
            queryables = [bk.post, bk.batch, bk.update, bk.delete, bk.retrieve, bk.lookup, bk.frames, bk.monitor, bk.stats,
                          sk.capture, sk.info, sk.map, mk.mission_submit, mk.mission_status("x"), mk.mission_cancel,
                          ek.service("controller", "position"), ek.service("controller", "command"),
                          ek.service("controller", "recorded_path"), ek.service("navigator", "world_from_local"),
                          ek.service("map_manager", "query")]
            subscribed = [bk.write("fuzzer"), sk.cmd, sk.odom, ek.inbox("controller"), ek.inbox("navigator"),
                          ek.inbox("map_manager"), ek.topic("controller", "state"), ek.topic("navigator", "world_from_local"),
                          *(bk.to_client(c) for c in clients)]
            res["queryables"], res["subscribed"] = len(queryables), len(subscribed)
            t0 = time.monotonic()
            for key in queryables:
                huge = (2 * 1024 * 1024, 10 * 1024 * 1024) if key == mk.mission_submit else (2 * 1024 * 1024,)
                batch = generate_payloads(rng, payloads, huge=huge)
                for at in range(0, len(batch), 32):
                    chunk = batch[at: at + 32]
                    answers = await asyncio.gather(*(link.get(key, data, timeout=10.0, as_json=bool(rng.integers(0, 2)))
                                                     for _kind, data in chunk))
                    for (kind, data), replies in zip(chunk, answers):
                        res["payloads"] += 1
                        if not replies:
                            res["ignored"] += 1
                            continue
                        for r in replies:
                            res["max_reply_bytes"] = max(res["max_reply_bytes"], len(r.payload))
                            problem = None
                            if not r.ok and len(r.payload) > MAX_REPLY_BYTES:
                                problem = f"a {len(r.payload)}-byte error reply"
                            elif not r.ok and r.payload == b"Timeout":
                                res["ignored"] += 1
                                continue
                            elif not r.ok and not _typed_error(r.payload):
                                problem = f"untyped error {r.payload[:120]!r}"
                            if problem is not None:
                                res["violation_count"] += 1
                                if len(res["violations"]) < 20:
                                    res["violations"].append({"key": key, "kind": kind, "bytes": len(data), "problem": problem})
                            elif r.ok:
                                res["answered"] += 1
                            else:
                                res["typed_errors"] += 1
            for key in subscribed:
                for i, (_kind, data) in enumerate(generate_payloads(rng, payloads)):
                    link.put(key, data, as_json=bool(i % 2))
                    res["payloads"] += 1
                    if i % 50 == 49:
                        await asyncio.sleep(0.01)  # let the receivers drain: a flood is the soak's business
            res["fuzz_seconds"] = round(time.monotonic() - t0, 2)
            # No pause for the last puts: each check is a valid request sent after them on the same links,
            # answered by the process's loop only after it took every earlier sample (Zenoh keeps a link's
            # order; samples and queries reach the loop in that order). Its reply is the event.
            res["not_serving_why"] = {}
            res["still_serving"] = await _still_serving(net, link, res["not_serving_why"])
            res["alive"] = {name: sup.alive(name) for name in sup.procs}
        finally:
            link.close()
    finally:
        res["exit_codes"] = await sup.stop_all()
    return res


def run(*, payloads: int = 10_000, seed: int = 0) -> dict:
    """Fuzz every endpoint with `payloads` payloads per key; return the figures (see the module docstring)."""
    with tempfile.TemporaryDirectory(prefix="sidewalk-fuzz-") as tmp:
        return asyncio.run(_fuzz(payloads, seed, Path(tmp)))
