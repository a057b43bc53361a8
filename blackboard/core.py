"""The blackboard's state machine: validate and apply operations, answer reads, match monitors.

Pure (no network): the node feeds it decoded wire objects (or the request models of
`blackboard.ops`, which validate them) and sends back what it returns. Each write result is
{"ok": value} or {"error": code, "message": text}.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from blackboard.codec import encode, pack_array_of_packed
from blackboard.errors import BlackboardError, InvalidTokenError, NotFoundError, VersionConflictError
from blackboard.evaluate import Evaluator
from blackboard.frames import FrameTree
from blackboard.geometry import parse_geometry_wire, parse_geometry_wire_fast
from blackboard.ops import (
    DeleteOp,
    LookupRequest,
    PoseOp,
    PostOp,
    RetrieveRequest,
    StaticOp,
    UpdateOp,
    parse_write,
    plain_post,
)
from blackboard.registry import TypeRegistry
from blackboard.replies import FrameEdge, FrameListing, NodeStats
from blackboard.spec import Spec, parse_spec
from blackboard.store import Record, Store, token_rid

__all__ = ["BlackboardCore", "Stats", "Monitor", "Change"]


@dataclass
class Stats:
    """Node counters (all since start); `snapshot` gives the NodeStats reply."""

    posts: int = 0
    updates: int = 0
    deletes: int = 0
    poses: int = 0
    statics: int = 0
    retrieves: int = 0
    lookups: int = 0
    monitors_registered: int = 0
    events: int = 0
    errors: int = 0
    commits: int = 0
    write_requests: int = 0
    bytes_in: int = 0
    bytes_out: int = 0
    #: time spent handling requests [µs]
    busy_us: int = 0

    def snapshot(self, *, tokens: int, monitors: int) -> NodeStats:
        """Return the counters with the tokens [-] and monitors [-] held now."""
        return NodeStats(**self.__dict__, tokens=tokens, monitors=monitors)


@dataclass
class Monitor:
    """A registered monitor: who, which spec, and (set-level specs) the ids matching now."""

    client: str
    mid: str
    spec: Spec
    set_level: bool
    types: set[str] | None
    members: set[int] = field(default_factory=set)
    #: the spec is a type (or nothing) alone: every change of those types matches
    trivial: bool = False


#: (kind, new record or None, old record or None)
Change = tuple[str, "Record | None", "Record | None"]


class BlackboardCore:
    """Apply operations to a Store and a FrameTree; match monitors; keep counters."""

    def __init__(self, store: Store, registry: TypeRegistry, frames: FrameTree | None = None) -> None:
        self.store = store
        self.registry = registry
        self.frames = frames if frames is not None else FrameTree()
        self.evaluator = Evaluator(store, self.frames)
        self.stats = Stats()
        self.monitors: dict[tuple[str, str], Monitor] = {}
        self._pose_count = 0
        #: the frame changes of the commit being applied, for the node to publish once it is committed:
        #: ["p", parent, child, x, y, yaw, stamp, hold (None: forever)] or ["s", parent, child, x, y, yaw]
        self.frame_log: list[list] = []
        for parent, child, x, y, yaw in store.static_frames():
            self.frames.set_static(parent, child, (x, y, yaw))
        for parent, child, stamp, x, y, yaw, hold in store.poses():
            self.frames.add_pose(parent, child, (x, y, yaw), stamp, hold=math.inf if hold >= 1e300 else hold)

    # ------------------------------------------------------------------ writes
    def apply_requests(self, requests: list[list[Any]]) -> tuple[list[list[dict]], list[Change]]:
        """Apply each request's ops in one transaction; return per-request results and the changes.

        Invalid ops get an error result and change nothing; valid ones are committed together.
        """
        store = self.store
        results: list[list[dict]] = []
        changes: list[Change] = []
        store.begin()
        try:
            for ops in requests:
                self.stats.write_requests += 1
                res = []
                for op in ops:
                    try:
                        res.append({"ok": self._apply(op, changes)})
                    except BlackboardError as exc:
                        self.stats.errors += 1
                        res.append(exc.to_wire())
                results.append(res)
            store.commit()
            self.stats.commits += 1
        except BaseException:
            store.rollback()
            self.frame_log.clear()
            self._reload_frames_if_needed(changes)
            raise
        return results, changes

    def _reload_frames_if_needed(self, changes: list[Change]) -> None:
        """After a failed commit the frame tree may hold uncommitted poses; rebuild it from the store."""
        fresh = FrameTree(history=self.frames.history, max_samples=self.frames.max_samples, inertial=self.frames.inertial)
        for parent, child, x, y, yaw in self.store.static_frames():
            fresh.set_static(parent, child, (x, y, yaw))
        for parent, child, stamp, x, y, yaw, hold in self.store.poses():
            fresh.add_pose(parent, child, (x, y, yaw), stamp, hold=math.inf if hold >= 1e300 else hold)
        self.frames = fresh
        self.evaluator.frames = fresh

    def _apply(self, raw: object, changes: list[Change]) -> Any:
        post = plain_post(raw)  # the common post without building its model; anything else is validated in full
        op: Any = None
        if post is None:
            try:
                op = parse_write(raw)
            except InvalidTokenError:
                if type(raw) is dict and raw.get("op", "post") == "post" and type(raw.get("type")) is str:
                    self.registry.model(raw["type"])  # an unknown type is the first thing to say
                raise
            if type(op) is PostOp:
                post = (op.type, op.attrs, op.frame, op.stamp, op.source, op.geometry, op.reply)
        if post is not None:
            typ, attrs, frame, stamp, source, geometry, reply = post
            rec = self._post(typ, attrs, frame, stamp, source, geometry)
            changes.append(("new", rec, None))
            self.stats.posts += 1
            return rec.id if reply == "id" else rec.wire()
        kind = type(op)
        if kind is UpdateOp:
            rec, old = self._update(op)
            changes.append(("updated", rec, old))
            self.stats.updates += 1
            return rec.wire()
        if kind is DeleteOp:
            old = self._delete(op)
            changes.append(("deleted", None, old))
            self.stats.deletes += 1
            return {"id": old.id}
        if kind is PoseOp:
            self._pose(op)
            self.stats.poses += 1
            return None
        assert kind is StaticOp
        self.frames.set_static(op.parent, op.child, op.pose)
        self.store.set_static(op.parent, op.child, op.pose)
        self.frame_log.append(["s", op.parent, op.child, *op.pose])
        self.stats.statics += 1
        return None

    def _post(self, typ: str, attrs: Any, frame: str, stamp: float, source: str, geometry: Any) -> Record:
        valid = self.registry.validate_raw(typ, attrs)
        kind, xy = (None, None) if geometry is None else parse_geometry_wire_fast(geometry)
        return self.store.insert(typ, stamp, source, frame, kind, xy, valid)

    def _existing(self, tid: str, expected_version: int | None) -> Record:
        rid = token_rid(tid)
        rec = self.store.get(rid) if rid is not None else None
        if rec is None:
            raise NotFoundError(f"no token with id {tid!r}"[:200])
        if expected_version is not None and expected_version != rec.version:
            raise VersionConflictError(f"token {rec.id} is at version {rec.version}, not {expected_version}")
        return rec

    def _update(self, op: UpdateOp) -> tuple[Record, Record]:
        old = self._existing(op.id, op.expected_version)
        given = op.model_fields_set
        attrs = self.registry.validate_raw(old.type, op.attrs) if "attrs" in given else old.attrs
        frame = op.frame if op.frame is not None else old.frame
        stamp = op.stamp if op.stamp is not None else old.stamp
        if "geometry" in given:
            kind, xy = (None, None) if op.geometry is None else parse_geometry_wire(op.geometry)
        else:
            kind, xy = old.kind, old.xy
        return self.store.replace(old, stamp, frame, kind, xy, attrs), old

    def _delete(self, op: DeleteOp) -> Record:
        old = self._existing(op.id, op.expected_version)
        self.store.remove(old)
        return old

    def _pose(self, op: PoseOp) -> None:
        hold = math.inf if op.hold is None else op.hold
        self.frames.add_pose(op.parent, op.child, op.pose, op.stamp, hold=hold)
        self.store.add_pose(op.parent, op.child, op.stamp, op.pose, hold)
        self.frame_log.append(["p", op.parent, op.child, *op.pose, op.stamp, op.hold])
        self._pose_count += 1
        if self._pose_count % 1000 == 0:
            self.store.prune_poses(op.child, op.stamp - self.frames.history)

    # ------------------------------------------------------------------ reads
    def retrieve(self, req: RetrieveRequest | object) -> list[dict]:
        """Answer a retrieve request (or a bare spec); geometry expressed in its output frame if given."""
        req, recs = self.select(req)
        if req.frame is None:
            return [r.wire() for r in recs]
        return [self.evaluator.express(r, req.frame, req.frame_stamp) for r in recs]

    def retrieve_packed(self, req: RetrieveRequest | object) -> bytes:
        """Answer a retrieve request as a msgpack array of tokens (pre-encoded tokens reused)."""
        req, recs = self.select(req)
        if req.frame is None:
            return pack_array_of_packed([r.packed() for r in recs])
        return encode([self.evaluator.express(r, req.frame, req.frame_stamp) for r in recs])

    def select(self, req: RetrieveRequest | object) -> tuple[RetrieveRequest, list[Record]]:
        """Validate a retrieve request (or a bare spec); return it and the matching records."""
        if not isinstance(req, RetrieveRequest):
            req = RetrieveRequest.trusted({"spec": parse_spec(req), "frame": None, "frame_stamp": None}, {"spec"})
        self.stats.retrieves += 1
        return req, self.evaluator.select(req.spec)

    def lookup(self, req: LookupRequest | object) -> list[float]:
        """Answer T_{target@target_stamp ← source@source_stamp} as [x [m], y [m], yaw [rad]]."""
        if not isinstance(req, LookupRequest):
            req = LookupRequest.parse(req)
        self.stats.lookups += 1
        return list(self.frames.lookup(req.target, req.target_stamp, req.source, req.source_stamp))

    def take_frame_log(self) -> list[list]:
        """Return the frame changes committed since the last call, and forget them."""
        log, self.frame_log = self.frame_log, []
        return log

    def frame_history(self) -> dict:
        """Return the whole frame tree with its bounds, for a client's frame cache (`blackboard.frame_cache`)."""
        f = self.frames
        return {"history": f.history, "max_samples": f.max_samples, "inertial": list(f.inertial), "edges": f.history_wire()}

    def frame_info(self) -> FrameListing:
        """Return the frame tree: edges (parent, child, static) and oldest/newest stamps of moving frames [s]."""
        edges = []
        for parent, child, static in self.frames.edges():
            if static:
                edges.append(FrameEdge(parent=parent, child=child, static=True))
            else:
                ts = self.frames._edges[child].ts
                edges.append(FrameEdge(parent=parent, child=child, static=False, oldest=ts[0], newest=ts[-1]))
        return FrameListing(edges=tuple(edges))

    def stats_snapshot(self) -> NodeStats:
        """Return the counters with the tokens and monitors held now."""
        return self.stats.snapshot(tokens=len(self.store), monitors=len(self.monitors))

    # ------------------------------------------------------------------ monitors
    def register_monitor(self, client: str, mid: str, spec_obj: object) -> Monitor:
        """Register (or replace) monitor `mid` of `client`."""
        spec = parse_spec(spec_obj)
        m = Monitor(client, mid, spec, spec.is_set_level(), spec.types())
        m.trivial = not m.set_level and not spec.where and spec.geometry is None and not spec.any_of
        if m.set_level:
            m.members = {r.rid for r in self.evaluator.select(spec)}
        self.monitors[(client, mid)] = m
        self.stats.monitors_registered += 1
        return m

    def cancel_monitor(self, client: str, mid: str) -> bool:
        """Drop one monitor; return whether it existed."""
        return self.monitors.pop((client, mid), None) is not None

    def drop_client(self, client: str) -> int:
        """Drop every monitor of a client; return how many."""
        keys = [k for k in self.monitors if k[0] == client]
        for k in keys:
            del self.monitors[k]
        return len(keys)

    def match_changes(self, changes: list[Change]) -> list[tuple[Monitor, dict]]:
        """Return (monitor, event wire dict) for every change a monitor should see, in commit order."""
        return [(m, {"kind": kind, "token": rec.wire()}) for m, kind, rec in self.match_records(changes)]

    def match_records(self, changes: list[Change]) -> list[tuple[Monitor, str, Record]]:
        """Return (monitor, event kind, record) for every change a monitor should see, in commit order."""
        if not self.monitors or not changes:
            return []
        out: list[tuple[Monitor, str, Record]] = []
        ev = self.evaluator
        for m in list(self.monitors.values()):
            touched = False
            for kind, new, old in changes:
                rec = new if new is not None else old
                assert rec is not None
                if m.types is not None and rec.type not in m.types:
                    continue
                touched = True
                if m.trivial:
                    hit = True
                elif m.set_level:
                    if kind == "deleted":
                        hit = old.rid in m.members  # type: ignore[union-attr]
                    else:
                        hit = ev.matches(m.spec, new)  # type: ignore[arg-type]
                else:
                    if kind == "new":
                        hit = ev.matches(m.spec, new)  # type: ignore[arg-type]
                    elif kind == "updated":
                        hit = ev.matches(m.spec, new) or ev.matches(m.spec, old)  # type: ignore[arg-type]
                    else:
                        hit = ev.matches(m.spec, old)  # type: ignore[arg-type]
                if hit:
                    out.append((m, kind, rec))
            if m.set_level and touched:
                m.members = {r.rid for r in ev.select(m.spec)}
        self.stats.events += len(out)
        return out
