"""The token store: SQLite in WAL mode with an R*Tree over geometry bounding boxes.

Tokens, poses and static frames live in the database file. The R*Tree is derived data: it lives in
an in-memory database attached to the same connection (`idx.token_rtree`), so it commits and
rolls back with the tokens, is rebuilt from the tokens when the store opens, and costs no
page writes to the WAL (an R*Tree insert in the file doubled the commit cost of a post).

The node holds an in-memory mirror of every token (for fast predicate evaluation and replies);
SQLite is the durable copy and the spatial index. Writes are staged in a transaction (`begin`,
`put`, `remove`, `add_pose`, `set_static`) and become visible in the mirror at `commit`.

Durability: `sync="normal"` (WAL, synchronous=NORMAL) survives a crash or SIGKILL of the node
process; `sync="full"` (synchronous=FULL, an fsync per commit) also survives power loss.
"""

from __future__ import annotations

import math
import sqlite3
from typing import Iterable, Iterator, Literal

import msgpack
import numpy as np

from blackboard.geometry import coords_to_wire

__all__ = ["Record", "Store", "SyncMode", "token_id", "token_rid"]

SyncMode = Literal["normal", "full"]

_SCHEMA = """
CREATE TABLE IF NOT EXISTS tokens(
  rid INTEGER PRIMARY KEY,
  type TEXT NOT NULL, version INTEGER NOT NULL, stamp REAL NOT NULL,
  source TEXT NOT NULL, frame TEXT NOT NULL, geom BLOB, attrs BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS poses(
  parent TEXT NOT NULL, child TEXT NOT NULL, stamp REAL NOT NULL,
  x REAL NOT NULL, y REAL NOT NULL, yaw REAL NOT NULL, hold REAL NOT NULL,
  PRIMARY KEY(child, stamp)) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS static_frames(
  child TEXT PRIMARY KEY, parent TEXT NOT NULL, x REAL NOT NULL, y REAL NOT NULL, yaw REAL NOT NULL);
"""


def token_id(rid: int) -> str:
    """Return the public token id of a row id."""
    return f"t{rid}"


def token_rid(tid: object) -> int | None:
    """Return the row id of a public token id, or None if it is not one."""
    if isinstance(tid, str) and len(tid) > 1 and tid[0] == "t" and tid[1:].isdigit() and len(tid) < 20:
        return int(tid[1:])
    return None


class Record:
    """One stored token: its fields, geometry as (kind, (N,2) float64 [m]) and the cached wire dict."""

    __slots__ = ("rid", "type", "version", "stamp", "source", "frame", "kind", "xy", "attrs", "_wire", "_shape", "_packed")

    def __init__(self, rid: int, type: str, version: int, stamp: float, source: str, frame: str,
                 kind: str | None, xy: np.ndarray | None, attrs: dict) -> None:
        self.rid = rid
        self.type = type
        self.version = version
        self.stamp = stamp
        self.source = source
        self.frame = frame
        self.kind = kind
        self.xy = xy
        self.attrs = attrs
        self._wire: dict | None = None
        self._shape = None
        self._packed: bytes | None = None

    @property
    def id(self) -> str:
        return token_id(self.rid)

    def wire(self) -> dict:
        """Return the token's wire dict (cached)."""
        w = self._wire
        if w is None:
            w = self._wire = {
                "id": token_id(self.rid),
                "type": self.type,
                "version": self.version,
                "stamp": self.stamp,
                "source": self.source,
                "frame": self.frame,
                "geometry": None if self.kind is None else coords_to_wire(self.kind, self.xy),
                "attrs": self.attrs,
            }
        return w

    def packed(self) -> bytes:
        """Return the msgpack encoding of the wire dict (cached)."""
        p = self._packed
        if p is None:
            p = self._packed = _packb(self.wire())
        return p

    def shape(self):
        """Return the shapely geometry in the token's own frame (cached)."""
        if self._shape is None and self.kind is not None:
            from blackboard.geometry import to_shapely

            self._shape = to_shapely(self.kind, self.xy)
        return self._shape

    def bbox(self) -> tuple[float, float, float, float] | None:
        """Return (minx, maxx, miny, maxy) [m] or None without geometry."""
        if self.xy is None:
            return None
        xy = self.xy
        if len(xy) == 1:
            x, y = float(xy[0, 0]), float(xy[0, 1])
            return (x, x, y, y)
        mn, mx = xy.min(axis=0), xy.max(axis=0)
        return (float(mn[0]), float(mx[0]), float(mn[1]), float(mx[1]))


_packb = msgpack.Packer(use_bin_type=True).pack


class Store:
    """SQLite-backed token store with an in-memory mirror and staged transactions."""

    def __init__(self, path: str = ":memory:", *, sync: SyncMode = "normal") -> None:
        if sync not in ("normal", "full"):
            raise ValueError(f"sync must be 'normal' or 'full', not {sync!r}")
        self.path = path
        self.sync = sync
        self._db = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute(f"PRAGMA synchronous={'FULL' if sync == 'full' else 'NORMAL'}")
        self._db.execute("PRAGMA temp_store=MEMORY")
        self._db.execute("PRAGMA cache_size=-65536")
        self._db.executescript(_SCHEMA)
        self._db.execute("ATTACH DATABASE ':memory:' AS idx")
        self._db.execute("CREATE VIRTUAL TABLE idx.token_rtree USING rtree(rid, minx, maxx, miny, maxy)")
        self.records: dict[int, Record] = {}
        self.by_type: dict[str, dict[int, None]] = {}
        self.by_frame: dict[str, dict[int, None]] = {}
        self._pending: dict[int, Record | None] = {}
        self._in_txn = False
        self._next_rid = 1
        self._load()

    # ------------------------------------------------------------------ loading
    def _load(self) -> None:
        unpack = msgpack.unpackb
        for rid, typ, ver, stamp, src, frame, geom, attrs in self._db.execute(
            "SELECT rid, type, version, stamp, source, frame, geom, attrs FROM tokens ORDER BY rid"
        ):
            kind, xy = None, None
            if geom is not None:
                g = unpack(geom)
                kind, xy = g[0], np.asarray(g[1], dtype=np.float64).reshape(-1, 2)
            rec = Record(rid, typ, ver, stamp, src, frame, kind, xy, unpack(attrs))
            self._mirror_put(rec)
        # ids are never reused: the next row id is above every row id ever handed out (deletes of
        # the newest tokens record a high-water mark in `meta`)
        top = self._db.execute("SELECT max(rid) FROM tokens").fetchone()[0] or 0
        hw = self._db.execute("SELECT value FROM meta WHERE key='next_rid'").fetchone()
        self._next_rid = max(top + 1, int(hw[0]) if hw else 1)
        self._db.execute("BEGIN")
        self._db.executemany(
            "INSERT INTO idx.token_rtree(rid, minx, maxx, miny, maxy) VALUES (?,?,?,?,?)",
            ((r.rid, *bb) for r in self.records.values() if (bb := r.bbox()) is not None),
        )
        self._db.execute("COMMIT")

    def poses(self) -> Iterator[tuple[str, str, float, float, float, float, float]]:
        """Yield stored (parent, child, stamp [s], x [m], y [m], yaw [rad], hold [s]) in time order."""
        yield from self._db.execute("SELECT parent, child, stamp, x, y, yaw, hold FROM poses ORDER BY stamp")

    def static_frames(self) -> Iterator[tuple[str, str, float, float, float]]:
        """Yield stored static frames (parent, child, x [m], y [m], yaw [rad])."""
        yield from self._db.execute("SELECT parent, child, x, y, yaw FROM static_frames")

    # ------------------------------------------------------------------ mirror
    def _mirror_put(self, rec: Record) -> None:
        self.by_type.setdefault(rec.type, {})[rec.rid] = None
        old = self.records.get(rec.rid)
        if old is not None and old.frame != rec.frame:
            self.by_frame.get(old.frame, {}).pop(rec.rid, None)
        self.by_frame.setdefault(rec.frame, {})[rec.rid] = None
        self.records[rec.rid] = rec

    def _mirror_remove(self, rid: int) -> None:
        rec = self.records.pop(rid, None)
        if rec is not None:
            d = self.by_type.get(rec.type)
            if d is not None:
                d.pop(rid, None)
            f = self.by_frame.get(rec.frame)
            if f is not None:
                f.pop(rid, None)

    def get(self, rid: int) -> Record | None:
        """Return the record (staged changes included) or None."""
        if rid in self._pending:
            return self._pending[rid]
        return self.records.get(rid)

    def __len__(self) -> int:
        return len(self.records)

    # ------------------------------------------------------------------ writing
    def begin(self) -> None:
        """Start a transaction."""
        self._db.execute("BEGIN")
        self._in_txn = True

    def insert(self, type: str, stamp: float, source: str, frame: str, kind: str | None,
               xy: np.ndarray | None, attrs: dict) -> Record:
        """Stage a new token (version 1); return its record."""
        geom = None if kind is None else _packb((kind, xy.tolist()))
        rid = self._next_rid
        self._db.execute(
            "INSERT INTO tokens(rid, type, version, stamp, source, frame, geom, attrs) VALUES (?,?,?,?,?,?,?,?)",
            (rid, type, 1, stamp, source, frame, geom, _packb(attrs)),
        )
        self._next_rid = rid + 1
        rec = Record(rid, type, 1, stamp, source, frame, kind, xy, attrs)
        rec.packed()  # encode once, at write time: retrieves reuse the bytes
        self._index(rec)
        self._pending[rec.rid] = rec
        return rec

    def insert_many(self, rows: Iterable[tuple[str, float, str, str, str | None, np.ndarray | None, dict]]) -> list[Record]:
        """Stage many new tokens (type, stamp, source, frame, kind, xy, attrs); return their records."""
        return [self.insert(*row) for row in rows]

    def replace(self, old: Record, stamp: float, frame: str, kind: str | None, xy: np.ndarray | None,
                attrs: dict) -> Record:
        """Stage a new version of `old`; return the new record."""
        geom = None if kind is None else _packb((kind, xy.tolist()))
        rec = Record(old.rid, old.type, old.version + 1, stamp, old.source, frame, kind, xy, attrs)
        self._db.execute(
            "UPDATE tokens SET version=?, stamp=?, frame=?, geom=?, attrs=? WHERE rid=?",
            (rec.version, stamp, frame, geom, _packb(attrs), rec.rid),
        )
        rec.packed()
        self._db.execute("DELETE FROM idx.token_rtree WHERE rid=?", (rec.rid,))
        self._index(rec)
        self._pending[rec.rid] = rec
        return rec

    def remove(self, rec: Record) -> None:
        """Stage the deletion of a token."""
        self._db.execute("DELETE FROM tokens WHERE rid=?", (rec.rid,))
        self._db.execute("DELETE FROM idx.token_rtree WHERE rid=?", (rec.rid,))
        self._db.execute("INSERT OR REPLACE INTO meta(key, value) VALUES ('next_rid', ?)", (self._next_rid,))
        self._pending[rec.rid] = None

    def _index(self, rec: Record) -> None:
        bb = rec.bbox()
        if bb is not None:
            self._db.execute("INSERT INTO idx.token_rtree(rid, minx, maxx, miny, maxy) VALUES (?,?,?,?,?)", (rec.rid, *bb))

    def add_pose(self, parent: str, child: str, stamp: float, pose: tuple[float, float, float], hold: float) -> None:
        """Stage a pose sample."""
        self._db.execute(
            "INSERT OR REPLACE INTO poses(parent, child, stamp, x, y, yaw, hold) VALUES (?,?,?,?,?,?,?)",
            (parent, child, stamp, pose[0], pose[1], pose[2], hold if math.isfinite(hold) else 1e300),
        )

    def prune_poses(self, child: str, before: float) -> None:
        """Stage dropping the pose samples of `child` older than `before` [s]."""
        self._db.execute("DELETE FROM poses WHERE child=? AND stamp<?", (child, before))

    def set_static(self, parent: str, child: str, pose: tuple[float, float, float]) -> None:
        """Stage a static frame."""
        self._db.execute(
            "INSERT OR REPLACE INTO static_frames(child, parent, x, y, yaw) VALUES (?,?,?,?,?)",
            (child, parent, *pose),
        )

    def commit(self) -> list[Record | int]:
        """Commit the transaction (durable per `sync`); publish staged changes to the mirror.

        Return the changes in order: a Record (new or updated) or a row id (deleted).
        """
        self._db.execute("COMMIT")
        self._in_txn = False
        changes: list[Record | int] = []
        for rid, rec in self._pending.items():
            if rec is None:
                self._mirror_remove(rid)
                changes.append(rid)
            else:
                self._mirror_put(rec)
                changes.append(rec)
        self._pending.clear()
        return changes

    def rollback(self) -> None:
        """Abandon the transaction and its staged changes."""
        if self._in_txn:
            self._db.execute("ROLLBACK")
            self._in_txn = False
        self._pending.clear()
        top = self._db.execute("SELECT max(rid) FROM tokens").fetchone()[0] or 0
        hw = self._db.execute("SELECT value FROM meta WHERE key='next_rid'").fetchone()
        self._next_rid = max(top + 1, int(hw[0]) if hw else 1, max(self.records, default=0) + 1)

    # ------------------------------------------------------------------ reading
    def bbox_query(self, minx: float, maxx: float, miny: float, maxy: float) -> list[int]:
        """Return the row ids whose bounding box meets the box [m] (committed tokens)."""
        return [
            r[0]
            for r in self._db.execute(
                "SELECT rid FROM idx.token_rtree WHERE minx<=? AND maxx>=? AND miny<=? AND maxy>=?",
                (maxx, minx, maxy, miny),
            )
        ]

    def close(self) -> None:
        """Close the database."""
        self.rollback()
        self._db.close()
