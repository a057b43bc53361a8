"""The blackboard's state machine: validate and apply operations, answer reads, match monitors.

Pure (no network): the node feeds it decoded wire objects and sends back what it returns.
Wire ops (dicts):
  {"op": "post", "type", "attrs", "frame", "stamp", "source", "geometry"?, "reply"?}
      ("reply": "id" answers just the new id instead of the whole token)
  {"op": "update", "id", "expected_version", "attrs"?, "frame"?, "stamp"?, "geometry"?}
  {"op": "delete", "id", "expected_version"?}
  {"op": "pose", "parent", "child", "pose": [x, y, yaw], "stamp", "hold"?}
  {"op": "static", "parent", "child", "pose": [x, y, yaw]}
Each result is {"ok": value} or {"error": code, "message": text}.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from blackboard.codec import encode, finite, pack_array_of_packed
from blackboard.errors import (
    BadRequestError,
    BadSpecError,
    BlackboardError,
    InvalidTokenError,
    NotFoundError,
    VersionConflictError,
)
from blackboard.evaluate import Evaluator
from blackboard.frames import FrameTree
from blackboard.geometry import parse_geometry_wire, parse_geometry_wire_fast
from blackboard.registry import TypeRegistry
from blackboard.spec import Spec, parse_spec
from blackboard.store import Record, Store, token_rid

__all__ = ["BlackboardCore", "Stats", "Monitor", "Change"]

_FRAME_RE = re.compile(r"^[A-Za-z0-9_.\-]{1,128}$")
_POST_KEYS = frozenset({"op", "type", "attrs", "frame", "stamp", "source", "geometry", "reply"})
_UPDATE_KEYS = frozenset({"op", "id", "expected_version", "attrs", "frame", "stamp", "geometry"})
_MISSING = object()
#: frame names already found valid (bounded)
_FRAMES_SEEN: set[str] = set()


@dataclass
class Stats:
    """Node counters (all since start)."""

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

    def as_dict(self) -> dict[str, int]:
        """Return the counters as a dict."""
        return dict(self.__dict__)


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


def _frame(v: object, what: str) -> str:
    if type(v) is str and v in _FRAMES_SEEN:
        return v  # type: ignore[return-value]
    if not isinstance(v, str) or not _FRAME_RE.match(v):
        raise InvalidTokenError(f"{what} {v!r} must be 1-128 characters of letters, digits, '_', '-', '.'")
    if len(_FRAMES_SEEN) < 4096:
        _FRAMES_SEEN.add(v)
    return v


def _stamp(v: object, what: str = "stamp") -> float:
    if not finite(v):
        raise InvalidTokenError(f"{what} {v!r} must be a finite number [s]")
    return float(v)  # type: ignore[arg-type]


def _pose3(v: object) -> tuple[float, float, float]:
    if not isinstance(v, (list, tuple)) or len(v) != 3 or not all(finite(c) for c in v):
        raise InvalidTokenError(f"pose {v!r} must be [x [m], y [m], yaw [rad]], all finite")
    return (float(v[0]), float(v[1]), float(v[2]))


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

    def _apply(self, op: object, changes: list[Change]) -> Any:
        if not isinstance(op, dict):
            raise BadRequestError(f"an operation must be an object, got {type(op).__name__}")
        kind = op.get("op", "post")
        if kind == "post":
            rec = self._post(op)
            changes.append(("new", rec, None))
            self.stats.posts += 1
            return rec.id if op.get("reply") == "id" else rec.wire()
        if kind == "update":
            rec, old = self._update(op)
            changes.append(("updated", rec, old))
            self.stats.updates += 1
            return rec.wire()
        if kind == "delete":
            old = self._delete(op)
            changes.append(("deleted", None, old))
            self.stats.deletes += 1
            return {"id": old.id}
        if kind == "pose":
            self._pose(op)
            self.stats.poses += 1
            return None
        if kind == "static":
            parent, child = _frame(op.get("parent"), "parent frame"), _frame(op.get("child"), "child frame")
            pose = _pose3(op.get("pose"))
            self.frames.set_static(parent, child, pose)
            self.store.set_static(parent, child, pose)
            self.stats.statics += 1
            return None
        raise BadRequestError(f"unknown operation {kind!r} (post, update, delete, pose, static)")

    def _post(self, op: dict) -> Record:
        if not _POST_KEYS.issuperset(op):
            extra = set(op) - _POST_KEYS
            raise InvalidTokenError(f"unexpected token fields {sorted(map(str, extra))[:5]}")
        typ = op.get("type")
        if not isinstance(typ, str):
            raise InvalidTokenError(f"token type must be a string, got {typ!r}"[:200])
        attrs = self.registry.validate_raw(typ, op.get("attrs", {}))
        frame = _frame(op.get("frame", "world"), "frame")
        stamp = _stamp(op.get("stamp"))
        source = op.get("source", "")
        if not isinstance(source, str) or len(source) > 128:
            raise InvalidTokenError(f"source must be a string of at most 128 characters")
        g = op.get("geometry")
        kind, xy = (None, None) if g is None else parse_geometry_wire_fast(g)
        return self.store.insert(typ, stamp, source, frame, kind, xy, attrs)

    def _existing(self, op: dict) -> Record:
        tid = op.get("id")
        rid = token_rid(tid)
        rec = self.store.get(rid) if rid is not None else None
        if rec is None:
            raise NotFoundError(f"no token with id {tid!r}"[:200])
        ev = op.get("expected_version", _MISSING)
        if ev is not _MISSING and ev is not None:
            if not isinstance(ev, int) or isinstance(ev, bool):
                raise BadRequestError(f"expected_version must be an integer, got {ev!r}"[:200])
            if ev != rec.version:
                raise VersionConflictError(f"token {rec.id} is at version {rec.version}, not {ev}")
        return rec

    def _update(self, op: dict) -> tuple[Record, Record]:
        extra = set(op) - _UPDATE_KEYS
        if extra:
            raise InvalidTokenError(f"unexpected update fields {sorted(map(str, extra))[:5]}")
        if "expected_version" not in op:
            raise BadRequestError("update needs expected_version (compare-and-set)")
        old = self._existing(op)
        attrs = self.registry.validate_raw(old.type, op["attrs"]) if "attrs" in op else old.attrs
        frame = _frame(op["frame"], "frame") if "frame" in op else old.frame
        stamp = _stamp(op["stamp"]) if "stamp" in op else old.stamp
        if "geometry" in op:
            g = op["geometry"]
            kind, xy = (None, None) if g is None else parse_geometry_wire(g)
        else:
            kind, xy = old.kind, old.xy
        return self.store.replace(old, stamp, frame, kind, xy, attrs), old

    def _delete(self, op: dict) -> Record:
        old = self._existing(op)
        self.store.remove(old)
        return old

    def _pose(self, op: dict) -> None:
        parent, child = _frame(op.get("parent"), "parent frame"), _frame(op.get("child"), "child frame")
        pose = _pose3(op.get("pose"))
        stamp = _stamp(op.get("stamp"))
        hold = op.get("hold", 0.0)
        if hold is None:
            hold = math.inf
        if not (finite(hold) or hold == math.inf) or hold < 0:
            raise InvalidTokenError(f"hold {hold!r} must be a number ≥ 0 [s] (or null: forever)")
        self.frames.add_pose(parent, child, pose, stamp, hold=float(hold))
        self.store.add_pose(parent, child, stamp, pose, float(hold))
        self._pose_count += 1
        if self._pose_count % 1000 == 0:
            self.store.prune_poses(child, stamp - self.frames.history)

    # ------------------------------------------------------------------ reads
    def retrieve(self, spec_obj: object, frame: str | None = None, frame_stamp: float | None = None) -> list[dict]:
        """Answer a spec; geometry expressed in `frame@frame_stamp` if a frame is given."""
        recs = self.select(spec_obj, frame, frame_stamp)
        if frame is None:
            return [r.wire() for r in recs]
        return [self.evaluator.express(r, frame, frame_stamp) for r in recs]

    def retrieve_packed(self, spec_obj: object, frame: str | None = None, frame_stamp: float | None = None) -> bytes:
        """Answer a spec as a msgpack array of tokens (pre-encoded tokens reused)."""
        recs = self.select(spec_obj, frame, frame_stamp)
        if frame is None:
            return pack_array_of_packed([r.packed() for r in recs])
        return encode([self.evaluator.express(r, frame, frame_stamp) for r in recs])

    def select(self, spec_obj: object, frame: str | None = None, frame_stamp: float | None = None) -> list[Record]:
        """Validate a spec and the output frame; return the matching records."""
        spec = parse_spec(spec_obj)
        if frame is not None:
            try:
                _frame(frame, "output frame")
            except InvalidTokenError as exc:
                raise BadSpecError(exc.message) from None
        if frame_stamp is not None and not finite(frame_stamp):
            raise BadSpecError(f"output frame stamp {frame_stamp!r} must be a finite number [s]")
        self.stats.retrieves += 1
        return self.evaluator.select(spec)

    def lookup(self, req: object) -> list[float]:
        """Answer T_{target@target_stamp ← source@source_stamp} as [x, y, yaw]."""
        if not isinstance(req, dict):
            raise BadRequestError("lookup needs an object {target, target_stamp, source, source_stamp}")
        target = _frame(req.get("target"), "target frame")
        source = _frame(req.get("source"), "source frame")
        ts, ss = req.get("target_stamp"), req.get("source_stamp")
        ts = None if ts is None else _stamp(ts, "target_stamp")
        ss = None if ss is None else _stamp(ss, "source_stamp")
        self.stats.lookups += 1
        return list(self.frames.lookup(target, ts, source, ss))

    def frame_info(self) -> dict:
        """Return the frame tree: edges (parent, child, static) and newest stamps of moving frames."""
        edges = []
        for parent, child, static in self.frames.edges():
            e: dict[str, Any] = {"parent": parent, "child": child, "static": static}
            if not static:
                e["newest"] = self.frames._edges[child].ts[-1]
                e["oldest"] = self.frames._edges[child].ts[0]
            edges.append(e)
        return {"edges": edges}

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
