"""The async blackboard client every module uses.

`BlackboardClient` is put together from three parts, each in a private module of its own:
the transport (`blackboard._client_transport`: writes coalesced into batches, one commit a message,
each call with its own acknowledgement or typed error; reads on the same channel; retries; writes
and queries held while the node is away and re-sent once it is back), the monitors
(`blackboard._client_monitors`: `MonitorStream`, `wait`), and the frames
(`blackboard._client_frames`: poses, lookups, transforms, the optional frame cache). This file
holds the client's life (open, close) and its tokens (post, update, delete, retrieve).

`post`, `post_raw`, `post_pose` and `set_static_frame` queue their request when called and return an
awaitable future (so `asyncio.gather(*[bb.post(...) for ...])` pipelines without a task per post);
`update`, `delete`, `retrieve`, `wait`, `lookup_pose` and `transform` are coroutines. Replies and
monitor events arrive on zenoh threads and are handed to the loop with `call_soon_threadsafe`.
"""

from __future__ import annotations

import asyncio
import re
import uuid
from typing import Any

from pydantic import BaseModel

from blackboard._client_frames import _Frames
from blackboard._client_monitors import MonitorStream, _Monitors
from blackboard._client_transport import MAX_WRITES_PER_MESSAGE, _distribute, _Transport
from blackboard.errors import NodeUnavailableError
from blackboard.geometry import Point, Polygon, Polyline
from blackboard.ops import DeleteOp, PostOp, RetrieveRequest, UpdateOp
from blackboard.registry import TypeRegistry, default_registry
from blackboard.replies import NodeStats
from blackboard.spec import Spec
from blackboard.token import Token, _geom_from_wire, make_token, token_from_owned_wire
from wire.keys import BlackboardKeys
from wire.network import NetworkConfig
from wire.session import open_session

__all__ = ["BlackboardClient", "MonitorStream", "MAX_WRITES_PER_MESSAGE"]

_SAFE = re.compile(r"[^A-Za-z0-9_-]")
#: every field of a PostOp, as its fields set (one set shared by all: a frozen model's is never changed in place)
_POST_FIELDS = set(PostOp.model_fields)


def _geom_wire(g: Point | Polyline | Polygon | None) -> dict | None:
    if g is None:
        return None
    if isinstance(g, Point):
        return {"kind": "point", "x": g.x, "y": g.y}
    if isinstance(g, (Polyline, Polygon)):
        return {"kind": g.kind, "points": [list(p) for p in g.points]}
    if isinstance(g, dict):
        return g
    raise TypeError(f"geometry must be Point, Polyline, Polygon or None, not {type(g).__name__}")


class BlackboardClient(_Frames, _Monitors, _Transport):
    """Async client of a blackboard node in `net.namespace`."""

    def __init__(
        self,
        net: NetworkConfig,
        *,
        source: str = "anonymous",
        registry: TypeRegistry | None = None,
        timeout: float = 10.0,
        connect_timeout: float = 10.0,
        lenient: bool = False,
        reconnect: bool = True,
        frame_cache: bool = False,
    ) -> None:
        self.net = net
        #: hold requests while the node is away and re-send them once it is back (False: fail them at once)
        self.reconnect = reconnect
        self.source = source
        self.registry = registry if registry is not None else default_registry
        self.timeout = timeout
        self.connect_timeout = connect_timeout
        #: keep attrs of types missing from the registry as plain dicts instead of raising UnknownTypeError
        self.lenient = lenient
        self.keys = BlackboardKeys(net.namespace)
        self.client_id = (_SAFE.sub("_", source)[:24] or "c") + "-" + uuid.uuid4().hex[:10]
        self._spec_cache: dict[int, tuple[Spec, dict]] = {}
        self._init_transport()
        self._init_monitors()
        self._init_frames(frame_cache)

    # ------------------------------------------------------------------ lifecycle
    @classmethod
    async def connect(cls, net: NetworkConfig, **kw: Any) -> "BlackboardClient":
        """Open a client and wait until the node is reachable (NodeUnavailableError after connect_timeout)."""
        self = cls(net, **kw)
        await self.open()
        return self

    async def open(self) -> None:
        """Open the zenoh session, declare this client's liveliness and wait for the node."""
        self._loop = loop = asyncio.get_running_loop()
        self._session = s = await loop.run_in_executor(None, open_session, self.net)
        s.liveliness_token(self.keys.client_alive(self.client_id))
        on_message = self._on_message
        s.subscribe_payload(self.keys.to_client(self.client_id), lambda _key, payload: loop.call_soon_threadsafe(on_message, payload))
        self._wpub = s.publisher(self.keys.write(self.client_id))
        if self.frame_cache is not None:  # subscribed before the whole tree is asked for: nothing falls between
            on_frames = self._on_frames_update
            s.subscribe_payload(self.keys.frame_updates, lambda _key, payload: loop.call_soon_threadsafe(on_frames, payload))
        s.liveliness_subscribe(self.keys.alive, lambda _key, alive: loop.call_soon_threadsafe(self._on_node, alive), history=True)
        try:
            await self.wait_node(timeout=self.connect_timeout)
        except (asyncio.TimeoutError, TimeoutError):
            await self.close()
            raise NodeUnavailableError(
                f"no blackboard node in namespace {self.net.namespace!r} within {self.connect_timeout} s "
                f"(endpoints {list(self.net.connect or self.net.listen)})"
            ) from None
        if self.frame_cache is not None:
            await self._prime_frames()

    async def close(self) -> None:
        """Cancel monitors, fail outstanding requests and close the session."""
        if self._closed:
            return
        for mon in list(self._monitors.values()):
            await mon.close()
        self._closed = True
        for _, fut, _ in self._batch:
            if not fut.done():
                fut.set_exception(NodeUnavailableError("client closed"))
        self._batch.clear()
        held, self._held = self._held, []
        for _, batch in held:
            _distribute(batch, None, NodeUnavailableError("client closed"))
        if self._resync_task is not None:
            self._resync_task.cancel()
        if self._prime_task is not None:
            self._prime_task.cancel()
        self._fail_inflight(NodeUnavailableError("client closed"))
        if self._session is not None:
            s, self._session = self._session, None
            s.close()

    async def __aenter__(self) -> "BlackboardClient":
        await self.open()
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()

    # ------------------------------------------------------------------ tokens
    def _token(self, w: dict, attrs: Any = None) -> Token:
        """Build the Token of a just-decoded wire dict (it becomes the token's fields)."""
        if attrs is None:
            if self.lenient and w["type"] not in self.registry:
                attrs = w["attrs"]
            else:
                attrs = self.registry.decode(w["type"], w["attrs"])
        return token_from_owned_wire(w, attrs)

    def _tokens(self, ws: list[dict]) -> list[Token]:
        """Build the Tokens of just-decoded wire dicts (they become the tokens' fields) as `_token` does,
        each type's attrs decoder looked up once."""
        decoders: dict[str, Any] = {}
        out = []
        for w in ws:
            typ = w["type"]
            dec = decoders.get(typ)
            if dec is None:
                dec = decoders[typ] = (_same if self.lenient and typ not in self.registry else self.registry.decoder(typ))
            out.append(token_from_owned_wire(w, dec(w["attrs"])))
        return out

    def _spec_wire(self, spec: Spec) -> dict:
        hit = self._spec_cache.get(id(spec))
        if hit is not None and hit[0] is spec:
            return hit[1]
        if isinstance(spec, dict):
            return spec
        w = spec.model_dump(mode="json")
        if len(self._spec_cache) > 256:
            self._spec_cache.clear()
        self._spec_cache[id(spec)] = (spec, w)
        return w

    def post(
        self,
        attrs: BaseModel,
        *,
        frame: str = "world",
        geometry: Point | Polyline | Polygon | None = None,
        stamp: float,
        type: str | None = None,
    ) -> "asyncio.Future[Token]":
        """Post a token; its type is the model's registered name. Await the Token (id, version 1).

        The request is queued when called (posts go out in call order; those made in the same loop
        iteration share one message and one commit, `MAX_WRITES_PER_MESSAGE` at most); the returned
        future resolves on the ack.
        """
        try:
            name = type or self.registry.name_of(attrs)
            g = _geom_wire(geometry)
            op = PostOp.trusted({
                "op": "post",
                "type": name,
                "attrs": attrs.__pydantic_serializer__.to_python(attrs, mode="json"),
                "frame": frame,
                "stamp": stamp,
                "source": self.source,
                "geometry": g,
                "reply": "id",
            }, _POST_FIELDS)
        except Exception as exc:  # noqa: BLE001 - raised when awaited, like any other failure
            return self._failed(exc)
        geom = _geom_from_wire(g) if isinstance(geometry, dict) else geometry
        source = self.source
        return self._write(op, lambda tid: make_token(tid, name, 1, float(stamp), source, frame, geom, attrs))

    def post_raw(
        self, type: str, attrs: dict, *, frame: str = "world", geometry: Any = None, stamp: float = 0.0
    ) -> "asyncio.Future[dict]":
        """Post a token from a raw attribute dict (validated by the node); await its wire dict."""
        try:
            g = _geom_wire(geometry)
        except Exception as exc:  # noqa: BLE001
            return self._failed(exc)
        return self._write(PostOp.trusted({"op": "post", "type": type, "attrs": attrs, "frame": frame, "stamp": stamp,
                                           "source": self.source, "geometry": g, "reply": None}, _POST_FIELDS))

    async def update(
        self,
        token_id: str,
        attrs: BaseModel | None = None,
        *,
        expected_version: int,
        geometry: Point | Polyline | Polygon | None | type(...) = ...,  # type: ignore[valid-type]
        stamp: float | None = None,
        frame: str | None = None,
    ) -> Token:
        """Replace a token's attrs/geometry/stamp/frame if it is still at `expected_version` (CAS).

        Raise VersionConflictError if someone else updated it first, NotFoundError if it is gone.
        """
        fields: dict[str, Any] = {"op": "update", "id": token_id, "expected_version": expected_version,
                                  "attrs": None, "frame": frame, "stamp": stamp, "geometry": None}
        given = {"op", "id", "expected_version"}
        if attrs is not None:
            fields["attrs"] = attrs.model_dump(mode="json")
            given.add("attrs")
        if geometry is not ...:
            fields["geometry"] = _geom_wire(geometry)  # type: ignore[arg-type]
            given.add("geometry")
        given.update(k for k in ("stamp", "frame") if fields[k] is not None)
        w = await self._write(UpdateOp.trusted(fields, given))
        return self._token(w, attrs)

    async def delete(self, token_id: str, *, expected_version: int | None = None) -> None:
        """Delete a token (optionally only if at `expected_version`)."""
        given = {"op", "id"} | ({"expected_version"} if expected_version is not None else set())
        await self._write(DeleteOp.trusted({"op": "delete", "id": token_id, "expected_version": expected_version}, given))

    async def retrieve_raw(self, spec: Spec | dict, *, frame: str | None = None, frame_stamp: float | None = None) -> list[dict]:
        """Return the matching tokens as wire dicts (attrs not decoded)."""
        # the body is the spec itself, or {"spec", "frame", "frame_stamp"} (docs/keys.md); the node validates it
        body: Any = self._spec_wire(spec)
        if frame is not None or frame_stamp is not None:
            req = RetrieveRequest.parse({"spec": spec, "frame": frame, "frame_stamp": frame_stamp})
            body = {"spec": body, "frame": req.frame, "frame_stamp": req.frame_stamp}
        return await self._read("retrieve", body)

    async def retrieve(self, spec: Spec, *, frame: str | None = None, frame_stamp: float | None = None) -> list[Token]:
        """Return the tokens matching `spec`; geometry in `frame` (at `frame_stamp`, default each token's stamp)."""
        return self._tokens(await self.retrieve_raw(spec, frame=frame, frame_stamp=frame_stamp))

    async def stats(self) -> NodeStats:
        """Return the node's counters (posts, retrieves, monitors, events, bytes in/out, tokens, …)."""
        return NodeStats.model_validate(await self._query(self.keys.stats, None))


def _same(x: Any) -> Any:
    return x
