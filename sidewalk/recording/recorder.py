"""Record every message of one Sidewalk system into an MCAP file (what `sidewalk record` and every run do).

What is recorded:

- every sample on `sidewalk/<ns>/**`, one channel per key, decoded from msgpack (or JSON) to JSON,
  stamped with the sim time it was received at (see `sink`); the raw blackboard write channel and
  the node's per-client messages too (except this recorder's own);
- liveliness tokens appearing and going (`/alive`);
- blackboard tokens as they are posted, updated and deleted (`/tokens/<type>`): the recorder is a
  blackboard client with one monitor matching every type; tokens already there when it starts are
  recorded as `present`;
- the map and world the simulator serves (`/sim/map`, `/sim/world`, answers to queries) and EDDIE's
  annotations (`/eddie/annotations`, the map manager's answer once its liveliness token appears and again at each
  mission's first event, when it holds that mission's annotations);
- Foxglove views of all this (`derive`): `/tf`, `/tf/truth`, `/tf_static`, `/scene/*`, `/camera/image`,
  `/colored_range/image`; under EDDIE the route (`/scene/route`) and the current segment (`/scene/segment`,
  `eddie_segment`) from the route annotations; and the map, world and annotations as `foxglove.GeoJSON` (`/geojson/*`, in
  WGS84 about `geo_anchor.GEO_ORIGIN`) for Foxglove's Map panel.

Zenoh callbacks only append to a deque; one writer thread decodes, converts and writes, so the
recorder never holds up a publisher (nothing is dropped either: the deque is unbounded).
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import json
import logging
import threading
import time
from pathlib import Path
from typing import Any

from blackboard import BlackboardClient, BlackboardError, Spec, Token
from modules.vocabulary import TOKEN_TYPES
from sidewalk.recording.channels import Family, decode_payload, family_of, topic_of
from sidewalk.recording.derive import annotation_points, annotation_scene, derive_sample, derive_token, map_scene, route_scene
from sidewalk.recording.eddie_segment import EddieSegment
from sidewalk.recording.geo_anchor import GEO_ORIGIN, annotations_geojson, map_geojson
from sidewalk.recording.foxglove import foxglove_schema
from sidewalk.recording.schemas import ALIVE_SCHEMA, token_schema
from sidewalk.recording.sink import McapSink
from wire.aio import Link
from wire.keys import Keys
from wire.session import Sample

__all__ = ["RunRecorder", "token_dict", "ANNOTATIONS_TOPIC"]

log = logging.getLogger(__name__)

#: The topic EDDIE's annotations (the answer to the map manager's query) are recorded on.
ANNOTATIONS_TOPIC = "/eddie/annotations"
#: the mission events stream (relative key): a mission's first event asks the map manager for its annotations again
MISSION_EVENTS = "mission/events"
_MODELS = {name: model for model, name in TOKEN_TYPES.items()}


def token_dict(tok: Token) -> dict:
    """Return a token as on the wire: id, type, version, stamp [s], source, frame, geometry, attrs (a dict)."""
    g = tok.geometry
    attrs = tok.attrs.model_dump(mode="json") if hasattr(tok.attrs, "model_dump") else tok.attrs
    return {"id": tok.id, "type": tok.type, "version": tok.version, "stamp": tok.stamp, "source": tok.source,
            "frame": tok.frame, "geometry": g.model_dump(mode="json") if g is not None else None, "attrs": attrs}


class RunRecorder:
    """Record namespace `ns` into `path`: `await start(bb)`, then `await stop()` (which closes the file)."""

    def __init__(self, link: Link, path: Path, ns: str, *, metadata: dict[str, str] | None = None,
                 drain_period_s: float = 0.05) -> None:
        self.link = link
        self.keys = Keys(ns)
        self.root = self.keys.root + "/"
        self.sink = McapSink(path, metadata={"namespace": ns, "geo_origin": f"{GEO_ORIGIN[0]},{GEO_ORIGIN[1]}", **(metadata or {})})
        self._q: collections.deque[tuple] = collections.deque()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="recorder-writer", daemon=True)
        self._drain_period = drain_period_s
        self._tasks: set[asyncio.Task] = set()
        self._skip_key: str | None = None
        self._schemas: dict[str, dict] = {}
        self._eddie_seen = False
        #: missions whose first event was seen (EDDIE: the map manager holds their annotations by then)
        self._missions_seen: set[str] = set()
        self._segment = EddieSegment()
        self._sim_seen = False
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopped = False
        self.clock = 0.0
        #: received samples, token events and liveliness changes (counted on arrival)
        self.received = 0
        self.errors = 0
        self.cpu_s = 0.0

    # ---- lifecycle (on the loop) ------------------------------------------------------------

    async def start(self, bb: BlackboardClient | None = None) -> None:
        """Subscribe to everything, start the writer thread; with `bb`, also monitor every token."""
        s = self.link.session
        self._loop = asyncio.get_running_loop()
        self._thread.start()
        if bb is not None:
            self._skip_key = bb.keys.to_client(bb.client_id)
        s.subscribe(self.root + "**", self._on_sample)
        s.liveliness_subscribe(self.root + "alive/**", self._on_alive, history=True)
        if bb is not None:
            await self.attach_blackboard(bb)

    async def attach_blackboard(self, bb: BlackboardClient) -> None:
        """Monitor every token type on `bb` (registered before this returns); record the tokens already there."""
        self._skip_key = bb.keys.to_client(bb.client_id)
        mon = bb.monitor(Spec())
        await mon.start()
        try:
            for tok in await bb.retrieve(Spec()):
                self._q.append(("t", "present", token_dict(tok)))
        except BlackboardError as exc:
            log.warning("recorder: cannot read the tokens already there: %s", exc)
        self._spawn(self._pump_tokens(mon))

    def _spawn(self, coro: Any) -> None:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _pump_tokens(self, mon: Any) -> None:
        async for ev in mon:
            self.received += 1
            self._q.append(("t", ev.kind, token_dict(ev.token)))

    def request_stop(self) -> None:
        """Stop receiving: cancel the token pump and tell the writer thread to finish (non-blocking)."""
        for t in list(self._tasks):
            t.cancel()
        self._stopped = True
        self._stop.set()

    def finish(self, timeout: float = 60.0) -> None:
        """Wait until the writer has written everything queued and closed the file (blocking)."""
        self.request_stop()
        if self._thread.is_alive():
            self._thread.join(timeout)
        elif not self.sink.closed:
            self._drain()
            self.sink.close()

    async def stop(self) -> None:
        """Stop receiving, write what is queued, close the file."""
        self.request_stop()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        await asyncio.to_thread(self.finish)

    # ---- Zenoh callbacks (Zenoh threads: append only) ----------------------------------------

    def _on_sample(self, sample: Sample) -> None:
        if self._stopped:
            return
        self.received += 1
        self._q.append(("s", sample))

    def _on_alive(self, key: str, alive: bool) -> None:
        if self._stopped:
            return
        self.received += 1
        self._q.append(("a", key, alive))

    # ---- queries for the static things (on the loop) ----------------------------------------

    async def _fetch_map(self) -> None:
        for rel, key in (("sim/map", self.keys.sim.map), ("sim/world", self.keys.sim.world)):
            for _ in range(5):
                replies = await self.link.get(key, timeout=5.0)
                ok = [r for r in replies if r.ok]
                if ok:
                    with contextlib.suppress(ValueError):
                        self._q.append(("j", rel, json.loads(ok[0].payload)))
                    break
                await asyncio.sleep(1.0)

    async def _fetch_annotations(self) -> None:
        key = self.keys.eddie.service("map_manager", "query")
        for _ in range(30):  # the token comes with the queryable; a loaded machine may answer late
            replies = await self.link.get(key, payload=json.dumps({"type": None, "polygon": None}).encode(), timeout=5.0, as_json=True)
            ok = [r for r in replies if r.ok]
            if ok:
                v = decode_payload(ok[0].payload, ok[0].is_json)
                anns = v.get("annotations", v) if isinstance(v, dict) else v
                if isinstance(anns, list) and anns:  # a map manager started empty gets each mission's annotations with it
                    self._q.append(("j", ANNOTATIONS_TOPIC[1:], anns))
                return
            await asyncio.sleep(1.0)

    # ---- the writer thread ------------------------------------------------------------------

    def _run(self) -> None:
        t0 = time.thread_time()
        try:
            while not self._stop.is_set():
                self._stop.wait(self._drain_period)
                self._drain()
            self._drain()
        finally:
            self.cpu_s = time.thread_time() - t0
            self.sink.close()

    def _drain(self) -> None:
        q = self._q
        while q:
            item = q.popleft()
            try:
                kind = item[0]
                if kind == "s":
                    self._write_sample(item[1])
                elif kind == "t":
                    self._write_token(item[1], item[2])
                elif kind == "a":
                    self._write_alive(item[1], item[2])
                elif kind == "j":
                    self._write_static(item[1], item[2])
            except Exception:  # noqa: BLE001 - one bad message must not end the recording
                self.errors += 1
                log.exception("recorder: cannot record %s", item[:2])

    def _schema(self, fam: Family) -> dict:
        s = self._schemas.get(fam.schema_name)
        if s is None:
            s = self._schemas[fam.schema_name] = fam.schema()
        return s

    def _write_sample(self, sample: Sample) -> None:
        key = sample.key
        if key == self._skip_key or not key.startswith(self.root):
            return
        rel = key[len(self.root):]
        if sample.deleted:
            value: Any = {"deleted": True}
        else:
            value = decode_payload(sample.payload, sample.is_json)
        own = None
        fam = family_of(rel)
        if isinstance(value, dict) and fam.stamp_field:
            v = value.get(fam.stamp_field)
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                own = float(v)
        if rel == "sim/clock" and own is not None:
            self.clock = max(self.clock, own)
        log_t = max(self.clock, own) if own is not None else self.clock
        topic = topic_of(rel)
        cid = self.sink.channel(topic, fam.schema_name, self._schema(fam), metadata={"key": key})
        log_t = self.sink.write(cid, topic, log_t, value, publish_s=own)
        derived = derive_sample(rel, value, log_t)
        if rel == MISSION_EVENTS and self._eddie_seen and isinstance(value, dict) and value.get("mission_id") not in self._missions_seen:
            self._missions_seen.add(str(value.get("mission_id")))
            self._call_soon(self._fetch_annotations)
        if rel.startswith("eddie/pub/") and isinstance(value, dict):
            derived += self._segment.on_stream(rel[len("eddie/pub/"):], value, log_t)
        for d in derived:
            self._write_derived(d.topic, d.schema, d.message, max(log_t, d.stamp), d.stamp)

    def _call_soon(self, fn: Any) -> None:
        with contextlib.suppress(RuntimeError):
            self._loop.call_soon_threadsafe(lambda: self._spawn(fn()))

    def _write_derived(self, topic: str, schema: str, msg: Any, log_t: float, stamp: float) -> None:
        cid = self.sink.channel(topic, schema, self._schemas.get(schema) or self._schemas.setdefault(schema, foxglove_schema(schema)))
        self.sink.write(cid, topic, log_t, msg.model_dump(mode="json"), publish_s=stamp)

    def _write_token(self, event: str, tok: dict) -> None:
        ttype = str(tok.get("type"))
        topic = f"/tokens/{ttype}"
        name = f"sidewalk.token.{ttype}"
        schema = self._schemas.get(name)
        if schema is None:
            schema = self._schemas[name] = token_schema(ttype, _MODELS.get(ttype))
        stamp = float(tok.get("stamp") or 0.0)
        log_t = max(self.clock, stamp)
        cid = self.sink.channel(topic, name, schema)
        log_t = self.sink.write(cid, topic, log_t, {"event": event, "token": tok}, publish_s=stamp)
        for d in derive_token(event, tok, log_t):
            self._write_derived(d.topic, d.schema, d.message, max(log_t, d.stamp), d.stamp)

    def _write_alive(self, key: str, alive: bool) -> None:
        cid = self.sink.channel("/alive", "sidewalk.Liveliness", ALIVE_SCHEMA)
        rel = key[len(self.root):] if key.startswith(self.root) else key
        self.sink.write(cid, "/alive", self.clock, {"key": key, "name": rel[len("alive/"):] if rel.startswith("alive/") else rel,
                                                    "alive": alive})
        if alive and key == self.keys.sim.alive and not self._sim_seen:
            self._sim_seen = True
            self._call_soon(self._fetch_map)
        if alive and key == self.keys.alive("map_manager") and not self._eddie_seen:
            self._eddie_seen = True
            self._call_soon(self._fetch_annotations)

    def _write_static(self, rel: str, value: Any) -> None:
        topic = "/" + rel
        fam = family_of(rel) if rel.startswith("sim/") else Family(rel, "sidewalk.eddie.Annotations", None, None)
        cid = self.sink.channel(topic, fam.schema_name, self._schema(fam))
        log_t = self.sink.write(cid, topic, self.clock, value if isinstance(value, dict) else {"payload": value})
        if rel in ("sim/map", "sim/world") and isinstance(value, dict):
            truth = rel == "sim/world"
            self._write_derived("/scene/world_truth" if truth else "/scene/map", "foxglove.SceneUpdate",
                                map_scene(value, log_t, truth=truth), log_t, log_t)
            self._write_derived("/geojson/world_truth" if truth else "/geojson/map", "foxglove.GeoJSON", map_geojson(value), log_t, log_t)
        elif rel == ANNOTATIONS_TOPIC[1:] and isinstance(value, list):
            anns = [a for a in value if isinstance(a, dict)]
            self._write_derived("/scene/annotations", "foxglove.SceneUpdate", annotation_scene(anns, log_t), log_t, log_t)
            self._write_derived("/geojson/annotations", "foxglove.GeoJSON", annotations_geojson(anns, annotation_points), log_t, log_t)
            self._segment.set_annotations(anns)
            route = self._segment.route.polyline()
            if len(route) >= 2:
                self._write_derived("/scene/route", "foxglove.SceneUpdate", route_scene("eddie-route", route, log_t), log_t, log_t)
