"""The token store: SQLite in WAL mode, with spatial indexes over token geometry.

Tokens, poses and static frames live in the database file. The spatial indexes are derived data,
rebuilt from the tokens when the store opens: point tokens (nearly all of them) are kept in an
in-memory hash grid per frame and token type (`blackboard.pointgrid`, updated as each commit is published: an
R*Tree insert cost 7–12 µs a row, the largest single cost of a post); the bounding boxes of other
geometries are in an R*Tree in an in-memory database attached to the same connection
(`idx.token_rtree`), so it commits and rolls back with the tokens and costs no page writes to the
WAL (an R*Tree insert in the file doubled the commit cost of a post).

The node holds an in-memory mirror of every token (for fast predicate evaluation and replies);
SQLite is the durable copy and the spatial index. Writes are staged in a transaction (`begin`,
`insert`, `replace`, `remove`, `add_pose`, `set_static`: the statements are kept, not run).

`commit` makes a transaction durable by appending its statements as one record to a journal file
beside the database (`<db>-bblog`: length, CRC-32, msgpack of the statements; one `write`, plus an
fsync under `sync="full"`), then publishes the changes to the mirror. `settle` (called by the node
once its acknowledgements and events are out, and before any read of SQLite) runs the journaled
statements in one SQLite transaction, brings the R*Tree up to date and empties the journal. A
store that opens with a non-empty journal replays it into SQLite first (every statement is
idempotent: rows are written whole by row id, so replaying what SQLite already holds is harmless)
and ignores a torn last record (a write that never completed was never acknowledged). This keeps
the SQLite commit, several times dearer than an append, off the path from a write to its
acknowledgement. With `:memory:` there is no journal.

Durability: `sync="normal"` (journal append to the OS, WAL with synchronous=NORMAL) survives a
crash or SIGKILL of the node process; `sync="full"` (fsync of the journal per commit,
synchronous=FULL) also survives power loss.
"""

from __future__ import annotations

import math
import os
import sqlite3
import struct
import zlib
from typing import Iterable, Iterator, Literal

import msgpack
import numpy as np

from blackboard.errors import StoreOpenError
from blackboard.limits import check_token_size
from blackboard.geometry import coords_to_wire
from blackboard.pointgrid import PointGrid

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
    """One stored token: its fields, geometry as (kind, (N,2) float64 [m]) and the cached wire dict.

    A point may be given as an (x, y) tuple [m]; its (1,2) array is then made on first use of `xy`.
    """

    __slots__ = ("rid", "type", "version", "stamp", "source", "frame", "kind", "_xy", "_pt", "attrs", "_wire", "_shape", "_packed")

    def __init__(self, rid: int, type: str, version: int, stamp: float, source: str, frame: str,
                 kind: str | None, xy: np.ndarray | tuple[float, float] | None, attrs: dict) -> None:
        self.rid = rid
        self.type = type
        self.version = version
        self.stamp = stamp
        self.source = source
        self.frame = frame
        self.kind = kind
        if type_(xy) is tuple:
            self._xy = None
            self._pt = xy
        else:
            self._xy = xy
            self._pt = None
        self.attrs = attrs
        self._wire: dict | None = None
        self._shape = None
        self._packed: bytes | None = None

    @property
    def xy(self) -> np.ndarray | None:
        """Return the (N,2) float64 coordinates [m] in the token's frame, or None without geometry."""
        xy = self._xy
        if xy is None and self._pt is not None:
            xy = self._xy = np.array((self._pt,), dtype=np.float64)
        return xy

    def point(self) -> tuple[float, float] | None:
        """Return (x, y) [m] of a point token, or None for any other geometry (or none)."""
        if self.kind != "point":
            return None
        pt = self._pt
        if pt is not None:
            return pt
        xy = self._xy
        return (float(xy[0, 0]), float(xy[0, 1]))  # type: ignore[index]

    def geom_packed(self) -> bytes | None:
        """Return the msgpack of (kind, [[x, y], …]) stored in SQLite, or None without geometry."""
        if self.kind is None:
            return None
        pt = self._pt
        return _packb((self.kind, ((pt[0], pt[1]),))) if pt is not None else _packb((self.kind, self.xy.tolist()))  # type: ignore[union-attr]

    @property
    def id(self) -> str:
        return token_id(self.rid)

    def _geometry_wire(self) -> dict | None:
        if self.kind is None:
            return None
        pt = self._pt
        if pt is not None:
            return {"kind": "point", "x": pt[0], "y": pt[1]}
        return coords_to_wire(self.kind, self.xy)  # type: ignore[arg-type]

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
                "geometry": self._geometry_wire(),
                "attrs": self.attrs,
            }
        return w

    def packed(self, attrs_packed: bytes | None = None) -> bytes:
        """Return the msgpack encoding of the wire dict (cached); `attrs_packed`: the attrs' msgpack, if already made.

        Made without building the wire dict: the same bytes as packing it (a map of the same
        keys in the same order), one dict fewer kept per token.
        """
        p = self._packed
        if p is None:
            if self._wire is not None:
                p = _packb(self._wire)
            else:
                # a 14-element array's encoding after its 1-byte head is the body of the map's first 7 pairs
                p = _MAP8 + _packb(("id", token_id(self.rid), "type", self.type, "version", self.version, "stamp", self.stamp,
                                    "source", self.source, "frame", self.frame, "geometry", self._geometry_wire()))[1:] + _ATTRS_KEY + (
                    _packb(self.attrs) if attrs_packed is None else attrs_packed)
            self._packed = p
        return p

    def shape(self):
        """Return the shapely geometry in the token's own frame (cached)."""
        if self._shape is None and self.kind is not None:
            from blackboard.geometry import to_shapely

            self._shape = to_shapely(self.kind, self.xy)
        return self._shape

    def bbox(self) -> tuple[float, float, float, float] | None:
        """Return (minx, maxx, miny, maxy) [m] or None without geometry."""
        pt = self._pt
        if pt is not None:
            return (pt[0], pt[0], pt[1], pt[1])
        xy = self._xy
        if xy is None:
            return None
        if len(xy) == 1:
            x, y = float(xy[0, 0]), float(xy[0, 1])
            return (x, x, y, y)
        mn, mx = xy.min(axis=0), xy.max(axis=0)
        return (float(mn[0]), float(mx[0]), float(mn[1]), float(mx[1]))


_packb = msgpack.Packer(use_bin_type=True).pack
_MAP8 = b"\x88"  # msgpack head of a map of 8 pairs
_ATTRS_KEY = _packb("attrs")


def _in_rtree(rec: Record) -> bool:
    """Return whether a record's bounding box belongs in the R*Tree (a geometry other than a point)."""
    return rec.kind is not None and rec.kind != "point"


def _points(xy: np.ndarray | tuple[float, float] | None) -> int:
    """Return how many points a record's geometry holds."""
    return 0 if xy is None else 1 if type(xy) is tuple else len(xy)


type_ = type
_INSERT = "INSERT OR REPLACE INTO tokens(rid, type, version, stamp, source, frame, geom, attrs) VALUES (?,?,?,?,?,?,?,?)"
_UPDATE = "UPDATE tokens SET version=?, stamp=?, frame=?, geom=?, attrs=? WHERE rid=?"
_DELETE = "DELETE FROM tokens WHERE rid=?"
_NEXT_RID = "INSERT OR REPLACE INTO meta(key, value) VALUES ('next_rid', ?)"
_POSE = "INSERT OR REPLACE INTO poses(parent, child, stamp, x, y, yaw, hold) VALUES (?,?,?,?,?,?,?)"
_PRUNE = "DELETE FROM poses WHERE child=? AND stamp<?"
_STATIC = "INSERT OR REPLACE INTO static_frames(child, parent, x, y, yaw) VALUES (?,?,?,?,?)"
#: journaled statements by code (the code, not the SQL text, is written to the journal)
_SQL = (_INSERT, _UPDATE, _DELETE, _NEXT_RID, _POSE, _PRUNE, _STATIC)
_CODE = {sql: i for i, sql in enumerate(_SQL)}
_FRAME = struct.Struct("<II")  # journal record head: body length [bytes], CRC-32 of the body
_IDX_INSERT = "INSERT INTO idx.token_rtree(rid, minx, maxx, miny, maxy) VALUES (?,?,?,?,?)"
_IDX_DELETE = "DELETE FROM idx.token_rtree WHERE rid=?"


class Store:
    """SQLite-backed token store with an in-memory mirror and staged transactions."""

    def __init__(self, path: str = ":memory:", *, sync: SyncMode = "normal") -> None:
        if sync not in ("normal", "full"):
            raise ValueError(f"sync must be 'normal' or 'full', not {sync!r}")
        self.path = path
        self.sync = sync
        try:
            self._db = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute(f"PRAGMA synchronous={'FULL' if sync == 'full' else 'NORMAL'}")
            # the node is the database's only user: holding the lock saves the per-transaction file
            # locking and shared-memory WAL index of the default mode
            self._db.execute("PRAGMA locking_mode=EXCLUSIVE")
            self._db.execute("PRAGMA temp_store=MEMORY")
            self._db.execute("PRAGMA cache_size=-65536")
            self._db.executescript(_SCHEMA)  # takes the exclusive lock: a database another node holds fails here
        except sqlite3.Error as exc:
            if "locked" in str(exc):
                raise StoreOpenError(f"database {path} is held by another blackboard node (SQLite: {exc}); "
                                     "stop that node or give another --db") from None
            raise StoreOpenError(f"cannot open database {path}: {exc}") from None
        self._db.execute("ATTACH DATABASE ':memory:' AS idx")
        self._db.execute("CREATE VIRTUAL TABLE idx.token_rtree USING rtree(rid, minx, maxx, miny, maxy)")
        self.records: dict[int, Record] = {}
        self.by_type: dict[str, dict[int, None]] = {}
        self.by_frame: dict[str, dict[int, None]] = {}
        #: frame → token type → the points of its point tokens (committed)
        self.points: dict[str, dict[str, PointGrid]] = {}
        #: committed tokens whose geometry is not a point (indexed in the R*Tree)
        self._shapes = 0
        self._pending: dict[int, Record | None] = {}
        #: statements of the open transaction: (sql, params), journaled at commit
        self._stmts: list[tuple[str, tuple]] = []
        #: committed (journaled) statements not yet run in SQLite
        self._unapplied: list[tuple[str, tuple]] = []
        self._rid_at_begin = 0
        #: committed changes not yet in the R*Tree (geometries other than points): (rid, record to index or None to delete)
        self._index_queue: list[tuple[int, Record | None]] = []
        self._in_txn = False
        self._next_rid = 1
        self._log_fd: int | None = None
        self._log_size = 0
        self.log_path: str | None = None
        if path not in ("", ":memory:") and not path.startswith("file:"):
            self.log_path = path + "-bblog"
            self._replay_log()
        self._load()

    # ------------------------------------------------------------------ loading
    def _replay_log(self) -> None:
        """Run the complete records of a journal left by a previous run into SQLite; empty it."""
        assert self.log_path is not None
        self._log_fd = fd = os.open(self.log_path, os.O_RDWR | os.O_CREAT | os.O_APPEND, 0o644)
        with open(self.log_path, "rb") as f:
            data = f.read()
        stmts: list[tuple[str, tuple]] = []
        pos, hs = 0, _FRAME.size
        while pos + hs <= len(data):
            n, crc = _FRAME.unpack_from(data, pos)
            body = data[pos + hs : pos + hs + n]
            if len(body) != n or zlib.crc32(body) != crc:
                break  # a torn last record: never acknowledged
            try:
                stmts.extend((_SQL[code], tuple(params)) for code, params in msgpack.unpackb(body))
            except Exception:  # noqa: BLE001 - a record that passed its CRC but does not decode
                break
            pos += hs + n
        if stmts:
            self._run(stmts, [])
        os.ftruncate(fd, 0)
        self._log_size = 0

    def _run(self, stmts: list[tuple[str, tuple]], index: list[tuple[int, "Record | None"]]) -> None:
        """Run statements, then R*Tree changes, in one SQLite transaction (consecutive alike: executemany)."""
        db = self._db
        if len(stmts) + len(index) == 1:
            if stmts:
                db.execute(*stmts[0])  # autocommit: the statement is its own transaction
            else:
                rid, rec = index[0]
                if rec is None:
                    db.execute(_IDX_DELETE, (rid,))
                else:
                    db.execute(_IDX_INSERT, (rid, *rec.bbox()))  # type: ignore[misc]
            return
        db.execute("BEGIN")
        try:
            i, n = 0, len(stmts)
            while i < n:
                sql = stmts[i][0]
                j = i + 1
                while j < n and stmts[j][0] is sql:
                    j += 1
                if j == i + 1:
                    db.execute(sql, stmts[i][1])
                else:
                    db.executemany(sql, [p for _, p in stmts[i:j]])
                i = j
            i, n = 0, len(index)
            while i < n:
                ins = index[i][1] is not None
                j = i + 1
                while j < n and (index[j][1] is not None) == ins:
                    j += 1
                if ins:
                    db.executemany(_IDX_INSERT, [(rid, *rec.bbox()) for rid, rec in index[i:j]])  # type: ignore[misc,union-attr]
                else:
                    db.executemany(_IDX_DELETE, [(rid,) for rid, _ in index[i:j]])
                i = j
            db.execute("COMMIT")
        except BaseException:
            if db.in_transaction:
                db.execute("ROLLBACK")
            raise

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
        self._db.executemany(_IDX_INSERT, ((r.rid, *r.bbox()) for r in self.records.values() if _in_rtree(r)))  # type: ignore[misc]
        self._db.execute("COMMIT")

    def poses(self) -> Iterator[tuple[str, str, float, float, float, float, float]]:
        """Yield stored (parent, child, stamp [s], x [m], y [m], yaw [rad], hold [s]) in time order."""
        self.settle()
        yield from self._db.execute("SELECT parent, child, stamp, x, y, yaw, hold FROM poses ORDER BY stamp")

    def static_frames(self) -> Iterator[tuple[str, str, float, float, float]]:
        """Yield stored static frames (parent, child, x [m], y [m], yaw [rad])."""
        self.settle()
        yield from self._db.execute("SELECT parent, child, x, y, yaw FROM static_frames")

    # ------------------------------------------------------------------ mirror
    def _mirror_put(self, rec: Record) -> None:
        rid = rec.rid
        self.by_type.setdefault(rec.type, {})[rid] = None
        old = self.records.get(rid)
        if old is not None:
            if old.frame != rec.frame:
                self.by_frame.get(old.frame, {}).pop(rid, None)
            if old.kind == "point" and (old.frame != rec.frame or rec.kind != "point"):
                self.points[old.frame][old.type].remove(rid)
            self._shapes -= _in_rtree(old)
        self._shapes += _in_rtree(rec)
        self.by_frame.setdefault(rec.frame, {})[rid] = None
        self.records[rid] = rec
        pt = rec.point()
        if pt is not None:
            grids = self.points.get(rec.frame)
            if grids is None:
                grids = self.points[rec.frame] = {}
            grid = grids.get(rec.type)
            if grid is None:
                grid = grids[rec.type] = PointGrid()
            grid.put(rid, pt[0], pt[1])

    def _mirror_remove(self, rid: int) -> None:
        rec = self.records.pop(rid, None)
        if rec is not None:
            d = self.by_type.get(rec.type)
            if d is not None:
                d.pop(rid, None)
            f = self.by_frame.get(rec.frame)
            if f is not None:
                f.pop(rid, None)
            if rec.kind == "point":
                self.points[rec.frame][rec.type].remove(rid)
            self._shapes -= _in_rtree(rec)

    def get(self, rid: int) -> Record | None:
        """Return the record (staged changes included) or None."""
        if rid in self._pending:
            return self._pending[rid]
        return self.records.get(rid)

    def __len__(self) -> int:
        return len(self.records)

    # ------------------------------------------------------------------ writing
    def begin(self) -> None:
        """Start a transaction (statements are staged until `commit`)."""
        if self._in_txn:
            raise RuntimeError("a transaction is already open")
        self._in_txn = True
        self._rid_at_begin = self._next_rid

    def insert(self, type: str, stamp: float, source: str, frame: str, kind: str | None,
               xy: np.ndarray | None, attrs: dict) -> Record:
        """Stage a new token (version 1); return its record. Raise TokenTooLargeError past its type's limit (nothing staged)."""
        rid = self._next_rid
        rec = Record(rid, type, 1, stamp, source, frame, kind, xy, attrs)
        geom, blob = rec.geom_packed(), _packb(attrs)
        check_token_size(type, len(blob) + (len(geom) if geom is not None else 0), _points(xy))
        self._stmts.append((_INSERT, (rid, type, 1, stamp, source, frame, geom, blob)))
        self._next_rid = rid + 1
        rec.packed(blob)  # encode once, at write time: retrieves and monitor events reuse the bytes
        self._pending[rid] = rec
        return rec

    def insert_many(self, rows: Iterable[tuple[str, float, str, str, str | None, np.ndarray | None, dict]]) -> list[Record]:
        """Stage many new tokens (type, stamp, source, frame, kind, xy, attrs); return their records."""
        return [self.insert(*row) for row in rows]

    def replace(self, old: Record, stamp: float, frame: str, kind: str | None, xy: np.ndarray | None,
                attrs: dict) -> Record:
        """Stage a new version of `old`; return the new record. Raise TokenTooLargeError past its type's limit (nothing staged)."""
        rec = Record(old.rid, old.type, old.version + 1, stamp, old.source, frame, kind, xy, attrs)
        geom, blob = rec.geom_packed(), _packb(attrs)
        check_token_size(old.type, len(blob) + (len(geom) if geom is not None else 0), _points(xy))
        self._stmts.append((_UPDATE, (rec.version, stamp, frame, geom, blob, rec.rid)))
        rec.packed(blob)
        self._pending[rec.rid] = rec
        return rec

    def remove(self, rec: Record) -> None:
        """Stage the deletion of a token."""
        self._stmts.append((_DELETE, (rec.rid,)))
        self._stmts.append((_NEXT_RID, (self._next_rid,)))
        self._pending[rec.rid] = None

    def add_pose(self, parent: str, child: str, stamp: float, pose: tuple[float, float, float], hold: float) -> None:
        """Stage a pose sample."""
        self._stmts.append((_POSE, (parent, child, stamp, pose[0], pose[1], pose[2], hold if math.isfinite(hold) else 1e300)))

    def prune_poses(self, child: str, before: float) -> None:
        """Stage dropping the pose samples of `child` older than `before` [s]."""
        self._stmts.append((_PRUNE, (child, before)))

    def set_static(self, parent: str, child: str, pose: tuple[float, float, float]) -> None:
        """Stage a static frame."""
        self._stmts.append((_STATIC, (child, parent, *pose)))

    def commit(self) -> list[Record | int]:
        """Make the staged statements durable (journal append, per `sync`); publish the changes to the mirror.

        Return the changes in order: a Record (new or updated) or a row id (deleted). On a
        failure nothing is committed, the transaction stays open for `rollback`, and the error is raised.
        """
        stmts = self._stmts
        if stmts:
            fd = self._log_fd
            if fd is not None:
                body = _packb([(_CODE[sql], params) for sql, params in stmts])
                rec = _FRAME.pack(len(body), zlib.crc32(body)) + body
                try:
                    if os.write(fd, rec) != len(rec):
                        raise OSError(f"short write to {self.log_path}")
                    if self.sync == "full":
                        os.fsync(fd)
                except BaseException:
                    try:
                        os.ftruncate(fd, self._log_size)  # drop a torn record: later ones must replay
                    except OSError:
                        pass
                    raise
                self._log_size += len(rec)
            self._unapplied.extend(stmts)
            self._stmts = []
        self._in_txn = False
        changes: list[Record | int] = []
        queue = self._index_queue
        for rid, rec in self._pending.items():  # type: ignore[assignment]
            if rec is None:
                old = self.records.get(rid)
                self._mirror_remove(rid)
                changes.append(rid)
                if old is not None and _in_rtree(old):
                    queue.append((rid, None))
            else:
                old = self.records.get(rid)
                self._mirror_put(rec)  # type: ignore[arg-type]
                changes.append(rec)  # type: ignore[arg-type]
                if old is not None and _in_rtree(old):
                    queue.append((rid, None))
                if _in_rtree(rec):  # type: ignore[arg-type]
                    queue.append((rid, rec))  # type: ignore[arg-type]
        self._pending.clear()
        return changes

    def unsettled(self) -> int:
        """Return how many committed statements and index changes wait for `settle`."""
        return len(self._unapplied) + len(self._index_queue)

    def settle(self) -> None:
        """Run the journaled statements and the R*Tree changes in SQLite (one transaction); empty the journal.

        On a failure (e.g. a full disk) everything stays queued, and journaled, for the next call.
        """
        stmts, index = self._unapplied, self._index_queue
        if not stmts and not index:
            return
        self._unapplied, self._index_queue = [], []
        try:
            self._run(stmts, index)
        except BaseException:
            self._unapplied, self._index_queue = stmts + self._unapplied, index + self._index_queue
            raise
        if stmts and self._log_fd is not None and not self._unapplied:
            os.ftruncate(self._log_fd, 0)
            self._log_size = 0

    def rollback(self) -> None:
        """Abandon the transaction and its staged changes."""
        if self._db.in_transaction:
            self._db.execute("ROLLBACK")
        if self._in_txn:
            self._next_rid = self._rid_at_begin
        self._in_txn = False
        self._stmts.clear()
        self._pending.clear()

    # ------------------------------------------------------------------ reading
    def bbox_query(self, minx: float, maxx: float, miny: float, maxy: float) -> list[int]:
        """Return the row ids whose bounding box meets the box [m] (committed tokens), points of every frame included."""
        rids = self.shapes_in_box(minx, maxx, miny, maxy)
        for grid in (g for grids in self.points.values() for g in grids.values()):
            prids, xy = grid.query(minx, maxx, miny, maxy)
            if prids:
                inside = (xy[:, 0] >= minx) & (xy[:, 0] <= maxx) & (xy[:, 1] >= miny) & (xy[:, 1] <= maxy)
                rids.extend(np.frombuffer(prids, dtype=np.int64)[inside].tolist())
        return rids

    def shapes_in_box(self, minx: float, maxx: float, miny: float, maxy: float) -> list[int]:
        """Return the row ids of the tokens other than points whose bounding box meets the box [m] (committed tokens)."""
        if not self._shapes:
            return []
        if self._index_queue:
            self.settle()
        return [
            r[0]
            for r in self._db.execute(
                "SELECT rid FROM idx.token_rtree WHERE minx<=? AND maxx>=? AND miny<=? AND maxy>=?",
                (maxx, minx, maxy, miny),
            )
        ]

    def points_in_box(self, frame: str, types: set[str] | None, minx: float, maxx: float, miny: float, maxy: float
                      ) -> tuple[np.ndarray, np.ndarray]:
        """Return the (N,) int64 row ids and (N,2) float64 points [m] of `frame`'s point tokens of `types` (None: any)
        near the box [m]: every one inside it, and others of the grid cells it meets (the caller tests the exact predicate)."""
        grids = self.points.get(frame, {})
        found = [grid.query(minx, maxx, miny, maxy) for t, grid in grids.items() if types is None or t in types]
        if len(found) == 1:
            return np.frombuffer(found[0][0], dtype=np.int64), found[0][1]
        if not found:
            return np.empty(0, dtype=np.int64), np.empty((0, 2), dtype=np.float64)
        return (np.concatenate([np.frombuffer(r, dtype=np.int64) for r, _ in found]),
                np.concatenate([xy for _, xy in found]))

    def close(self) -> None:
        """Settle what is committed into SQLite, drop the journal and close the database."""
        self.rollback()
        try:
            self.settle()
        finally:
            if self._log_fd is not None:
                os.close(self._log_fd)
                self._log_fd = None
                if not self._unapplied and self.log_path is not None:
                    try:
                        os.unlink(self.log_path)
                    except OSError:
                        pass
            self._db.close()
