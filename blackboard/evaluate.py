"""Evaluate retrieval specifications against the store and the frame tree (pure: no network).

Geometric predicates are stated in a frame F at a time s. Tokens whose frame G relates to F by a
time-invariant transform are found through the store's spatial indexes (the predicate's region
mapped into G): point tokens from the point grid, tested together on their coordinates; other
geometries from the R*Tree, tested shape by shape. Tokens in moving frames (e.g. `vehicle@t`) are mapped one by one into F@s with the pose history
at their own stamp. Tokens whose geometry cannot be expressed in F (no pose at their stamp, or
frames not connected) do not match a geometric predicate.
"""

from __future__ import annotations

import operator
from typing import Callable, Iterable

import numpy as np
import shapely

from blackboard.errors import BlackboardError, ExtrapolationError, UnknownFrameError
from blackboard.frames import FrameTree
from blackboard.geometry import Polygon, geometry_coords, polygon_shape, to_shapely
from blackboard.spec import AttrPredicate, Intersects, Near, Nearest, Spec, Within
from blackboard.store import Record, Store
from wire.se2 import SE2, transform_points

__all__ = ["Evaluator", "attr_get", "attr_match", "MISSING"]


class _Missing:
    def __repr__(self) -> str:
        return "MISSING"


MISSING = _Missing()

_CMP: dict[str, Callable[[object, object], bool]] = {
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}


def attr_get(attrs: object, path: str) -> object:
    """Return the value at dotted `path` in nested dicts/lists, or MISSING."""
    cur = attrs
    for part in path.split("."):
        if isinstance(cur, dict):
            if part not in cur:
                return MISSING
            cur = cur[part]
        elif isinstance(cur, (list, tuple)):
            try:
                i = int(part)
            except ValueError:
                return MISSING
            if not -len(cur) <= i < len(cur):
                return MISSING
            cur = cur[i]
        else:
            return MISSING
    return cur


def attr_match(pred: AttrPredicate, attrs: object) -> bool:
    """Return True if the predicate holds on the attribute dict."""
    v = attr_get(attrs, pred.path)
    op = pred.op
    if op == "exists":
        return (v is not MISSING) == bool(pred.value)
    if v is MISSING:
        return op == "!="
    if op == "==":
        return _eq(v, pred.value)
    if op == "!=":
        return not _eq(v, pred.value)
    if op == "in":
        return any(_eq(v, x) for x in pred.value)
    a, b = v, pred.value
    if isinstance(a, list) and isinstance(b, tuple):
        b = list(b)
    if isinstance(a, bool) != isinstance(b, bool):
        return False
    try:
        return bool(_CMP[op](a, b))
    except TypeError:
        return False


def _eq(a: object, b: object) -> bool:
    if isinstance(a, bool) != isinstance(b, bool):
        return False
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_eq(x, y) for x, y in zip(a, b))
    return a == b


class _Region:
    """A geometric predicate prepared in its own frame at a resolved time."""

    def __init__(self, pred: Within | Intersects | Near | Nearest, frames: FrameTree) -> None:
        self.pred = pred
        self.frame = pred.frame
        if pred.stamp is not None:
            self.stamp = float(pred.stamp)
        else:
            try:
                self.stamp = frames.latest_time(pred.frame)
            except BlackboardError:
                self.stamp = 0.0
        if isinstance(pred, Within):
            g = pred.polygon
        elif isinstance(pred, Nearest):
            g = pred.point
        else:
            g = pred.geometry
        if type(g) is Polygon:
            self.kind = "polygon"
            self.xy, self.shape = polygon_shape(g)
        else:
            self.kind, self.xy = geometry_coords(g)
            self.shape = to_shapely(self.kind, self.xy)
        shapely.prepare(self.shape)
        self.pad = pred.distance if isinstance(pred, Near) else 0.0

    def test(self, shapes: list) -> np.ndarray:
        """Return a bool mask: which token shapes (in this region's frame) satisfy the predicate."""
        if not shapes:
            return np.zeros(0, dtype=bool)
        arr = np.array(shapes, dtype=object)
        p = self.pred
        if isinstance(p, Within):
            return shapely.covers(self.shape, arr)
        if isinstance(p, Intersects):
            return shapely.intersects(self.shape, arr)
        if isinstance(p, Near):
            return shapely.distance(self.shape, arr) <= p.distance + 1e-12
        return np.ones(len(shapes), dtype=bool)

    def test_points(self, xy: np.ndarray) -> np.ndarray:
        """Return a bool mask: which (N,2) points [m] (in this region's frame) satisfy the predicate."""
        if isinstance(self.pred, (Within, Intersects)):
            return shapely.intersects_xy(self.shape, xy[:, 0], xy[:, 1])
        return self.test(list(shapely.points(xy)))

    def test_records(self, recs: list[Record], T: SE2 | None) -> np.ndarray:
        """Return a bool mask over records whose geometry, mapped by T (None: as stored) into this
        region's frame, satisfies the predicate; points are tested from coordinates, not objects."""
        n = len(recs)
        mask = np.zeros(n, dtype=bool)
        if not n:
            return mask
        pidx = [i for i, r in enumerate(recs) if r.kind == "point"]
        if pidx:
            xy = np.concatenate([recs[i].xy for i in pidx])
            mask[pidx] = self.test_points(xy if T is None else transform_points(T, xy))
        if len(pidx) < n:
            oidx = [i for i, r in enumerate(recs) if r.kind != "point"]
            shapes = [recs[i].shape() if T is None else to_shapely(recs[i].kind, transform_points(T, recs[i].xy)) for i in oidx]
            mask[oidx] = self.test(shapes)
        return mask


class Evaluator:
    """Answer specs from a Store and a FrameTree."""

    def __init__(self, store: Store, frames: FrameTree) -> None:
        self.store = store
        self.frames = frames

    # ------------------------------------------------------------------ helpers
    def _candidates(self, spec: Spec) -> Iterable[int]:
        types = spec.types()
        if types is None:
            return self.store.records.keys()
        if len(types) == 1:
            return self.store.by_type.get(next(iter(types)), {}).keys()
        rids: list[int] = []
        for t in types:
            rids.extend(self.store.by_type.get(t, {}).keys())
        rids.sort()
        return rids

    def _plain_ok(self, spec: Spec, rec: Record) -> bool:
        if spec.type is not None and rec.type != spec.type:
            return False
        for p in spec.where:
            if not attr_match(p, rec.attrs):
                return False
        return True

    def shape_in(self, rec: Record, frame: str, stamp: float, cache: dict | None = None):
        """Return the token's shapely geometry expressed in `frame@stamp`; raise Extrapolation/UnknownFrame."""
        if rec.frame == frame and (rec.stamp == stamp or self.frames.time_invariant(frame, rec.frame)):
            return rec.shape()
        key = (rec.frame, rec.stamp)
        T = cache.get(key) if cache is not None else None
        if T is None:
            T = self.frames.lookup(frame, stamp, rec.frame, rec.stamp)
            if cache is not None:
                cache[key] = T
        return to_shapely(rec.kind, transform_points(T, rec.xy))

    def _geo_select(self, region: _Region, spec: Spec, tail_ok: Callable[[Record], bool]) -> list[Record]:
        """Return the records satisfying the region (not nearest), the plain filters and `tail_ok`."""
        store, frames = self.store, self.frames
        records = store.records
        hits: list[int] = []  # row ids: each token is in one frame, and in its point grid or the R*Tree, not both
        types = spec.types()
        for gframe, rids in list(store.by_frame.items()):
            if not rids:
                continue
            if frames.time_invariant(region.frame, gframe):
                try:
                    T = frames.lookup(gframe, 0.0, region.frame, 0.0)  # region frame -> token frame
                except BlackboardError:
                    continue
                identity = T == (0.0, 0.0, 0.0)
                xy = region.xy if identity else transform_points(T, region.xy)
                xs, ys, pad = xy[:, 0].tolist(), xy[:, 1].tolist(), region.pad
                # widened by a rounding margin: the exact test below is made in the region's frame
                minx, miny = (v - pad - 1e-9 * (1.0 + abs(v)) for v in (min(xs), min(ys)))
                maxx, maxy = (v + pad + 1e-9 * (1.0 + abs(v)) for v in (max(xs), max(ys)))
                Tinv = None if identity else frames.lookup(region.frame, 0.0, gframe, 0.0)
                prids, pxy = store.points_in_box(gframe, types, minx, maxx, miny, maxy)
                if len(prids):
                    # the geometric test first, on every point (of the types asked for) at once; then the
                    # per-token filters on what passed
                    inside = region.test_points(pxy if Tinv is None else transform_points(Tinv, pxy))
                    if not spec.where and not spec.any_of:
                        hits.extend(prids[inside].tolist())
                    else:
                        for rid in prids[inside].tolist():
                            rec = records[rid]
                            if self._plain_ok(spec, rec) and tail_ok(rec):
                                hits.append(rid)
                cands = []
                for rid in store.shapes_in_box(minx, maxx, miny, maxy):
                    rec = records.get(rid)
                    if rec is None or rec.frame != gframe or (types is not None and rec.type not in types):
                        continue
                    if self._plain_ok(spec, rec) and tail_ok(rec):
                        cands.append(rec)
                if not cands:
                    continue
                mask = region.test_records(cands, Tinv)
                hits.extend(r.rid for r, ok in zip(cands, mask) if ok)
            elif frames.connected(region.frame, gframe):
                cands, shapes, cache = [], [], {}
                for rid in rids:
                    rec = records.get(rid)
                    if rec is None or rec.kind is None or (types is not None and rec.type not in types):
                        continue
                    if not (self._plain_ok(spec, rec) and tail_ok(rec)):
                        continue
                    try:
                        shapes.append(self.shape_in(rec, region.frame, region.stamp, cache))
                    except (ExtrapolationError, UnknownFrameError):
                        continue
                    cands.append(rec)
                mask = region.test(shapes)
                hits.extend(r.rid for r, ok in zip(cands, mask) if ok)
        hits.sort()
        return [records[rid] for rid in hits]

    def _nearest(self, region: _Region, spec: Spec, tail_ok: Callable[[Record], bool]) -> list[Record]:
        """Return the k records closest to the region's point (ties by id)."""
        k = region.pred.k  # type: ignore[union-attr]
        pt = region.shape
        store = self.store
        # exact distance to every plain-matching token with geometry, using the R*Tree for
        # time-invariant frames by growing a search box until k are found inside its radius.
        best: list[tuple[float, int, Record]] = []
        types = spec.types()
        for gframe, rids in list(store.by_frame.items()):
            if not rids:
                continue
            if self.frames.time_invariant(region.frame, gframe):
                try:
                    T = self.frames.lookup(gframe, 0.0, region.frame, 0.0)
                    Tinv = self.frames.lookup(region.frame, 0.0, gframe, 0.0)
                except BlackboardError:
                    continue
                c = transform_points(T, region.xy)[0]
                r = 1.0
                n_frame = len(rids)
                while True:
                    found = []
                    for rid in store.bbox_query(c[0] - r, c[0] + r, c[1] - r, c[1] + r):
                        rec = store.records.get(rid)
                        if rec is None or rec.frame != gframe or (types is not None and rec.type not in types):
                            continue
                        if self._plain_ok(spec, rec) and tail_ok(rec):
                            shp = rec.shape() if Tinv == (0.0, 0.0, 0.0) else to_shapely(rec.kind, transform_points(Tinv, rec.xy))
                            d = float(shapely.distance(pt, shp))
                            if d <= r:
                                found.append((d, rid, rec))
                    if len(found) >= k or r > 1e7 or len(found) >= n_frame:
                        break
                    r *= 4.0
                best.extend(found)
            elif self.frames.connected(region.frame, gframe):
                cache: dict = {}
                for rid in rids:
                    rec = store.records.get(rid)
                    if rec is None or rec.kind is None or (types is not None and rec.type not in types):
                        continue
                    if not (self._plain_ok(spec, rec) and tail_ok(rec)):
                        continue
                    try:
                        shp = self.shape_in(rec, region.frame, region.stamp, cache)
                    except (ExtrapolationError, UnknownFrameError):
                        continue
                    best.append((float(shapely.distance(pt, shp)), rid, rec))
        best.sort(key=lambda x: (x[0], x[1]))
        return [r for _, _, r in best[:k]]

    # ------------------------------------------------------------------ public
    def select(self, spec: Spec) -> list[Record]:
        """Return the records matching `spec`, in id order (nearest: by distance)."""
        tail_ok = self._any_of_filter(spec)
        geo = spec.geometry
        if geo is None:
            recs = [r for rid in self._candidates(spec) if (r := self.store.records.get(rid)) is not None
                    and self._plain_ok(spec, r) and tail_ok(r)]
        else:
            region = _Region(geo, self.frames)
            if isinstance(geo, Nearest):
                recs = self._nearest(region, spec, tail_ok)
            else:
                recs = self._geo_select(region, spec, tail_ok)
        if spec.newest and recs:
            recs = [max(recs, key=lambda r: (r.stamp, r.rid))]
        if spec.limit is not None:
            recs = recs[: spec.limit]
        return recs

    def _any_of_filter(self, spec: Spec) -> Callable[[Record], bool]:
        if not spec.any_of:
            return lambda rec: True
        subs: list[Callable[[Record], bool]] = []
        for sub in spec.any_of:
            if sub.is_set_level():
                ids = {r.rid for r in self.select(sub)}
                subs.append(lambda rec, ids=ids: rec.rid in ids)
            else:
                subs.append(lambda rec, sub=sub: self.matches(sub, rec))
        return lambda rec: any(f(rec) for f in subs)

    def matches(self, spec: Spec, rec: Record) -> bool:
        """Return True if one record matches a spec on its own (set-level parts use the whole store)."""
        if spec.is_set_level():
            return any(r.rid == rec.rid and r.version == rec.version for r in self.select(spec))
        if not self._plain_ok(spec, rec):
            return False
        if spec.any_of and not any(self.matches(s, rec) for s in spec.any_of):
            return False
        geo = spec.geometry
        if geo is None:
            return True
        if rec.kind is None:
            return False
        region = _Region(geo, self.frames)
        try:
            shp = self.shape_in(rec, region.frame, region.stamp)
        except (ExtrapolationError, UnknownFrameError):
            return False
        return bool(region.test([shp])[0])

    def express(self, rec: Record, frame: str | None, stamp: float | None) -> dict:
        """Return the token's wire dict with geometry expressed in `frame@stamp` (stamp None: the token's own)."""
        w = rec.wire()
        if frame is None or frame == rec.frame and (stamp is None or stamp == rec.stamp):
            return w
        if rec.kind is None:
            return {**w, "frame": frame}
        T = self.frames.lookup(frame, rec.stamp if stamp is None else stamp, rec.frame, rec.stamp)
        xy = transform_points(T, rec.xy)
        from blackboard.geometry import coords_to_wire

        return {**w, "frame": frame, "geometry": coords_to_wire(rec.kind, xy)}
