"""An in-memory spatial hash of point tokens: row id → (x, y) [m], bucketed in square cells of one frame.

Point tokens are nearly every token a run posts, and an SQLite R*Tree insert costs 7–12 µs a row
(a post's largest single cost, measured on the 2-core box), while an insert here costs well under a
microsecond. Each cell keeps its row ids and coordinates in flat arrays, so a box query copies
whole cells (no Python object per point) and hands back one (N,2) array on which the exact
predicate is tested at once. The answer is a superset of the points in the box (whole cells),
never missing one; callers test the exact predicate.
"""

from __future__ import annotations

from array import array

import numpy as np

__all__ = ["PointGrid", "CELL"]

#: side of a cell [m]: a retrieve of tens of metres visits tens of cells
CELL = 8.0


class _Cell:
    """The points of one cell: row ids and interleaved x, y [m], in the same order."""

    __slots__ = ("rids", "xy")

    def __init__(self) -> None:
        self.rids = array("q")
        self.xy = array("d")


class PointGrid:
    """Points [m] of one frame's tokens by row id, bucketed in `cell` [m] squares."""

    __slots__ = ("cell", "_cells", "_where")

    def __init__(self, cell: float = CELL) -> None:
        self.cell = cell
        #: (x // cell, y // cell) → its points
        self._cells: dict[tuple[float, float], _Cell] = {}
        #: row id → (its cell's key, its index in the cell)
        self._where: dict[int, tuple[tuple[float, float], int]] = {}

    def __len__(self) -> int:
        return len(self._where)

    def put(self, rid: int, x: float, y: float) -> None:
        """Add the point of row `rid` at (x, y) [m], or move it there."""
        c = self.cell
        key = (x // c, y // c)
        at = self._where.get(rid)
        if at is not None:
            if at[0] == key:
                xy = self._cells[key].xy
                i = 2 * at[1]
                xy[i] = x
                xy[i + 1] = y
                return
            self.remove(rid)
        cell = self._cells.get(key)
        if cell is None:
            cell = self._cells[key] = _Cell()
        self._where[rid] = (key, len(cell.rids))
        cell.rids.append(rid)
        cell.xy.append(x)
        cell.xy.append(y)

    def remove(self, rid: int) -> None:
        """Drop the point of row `rid` (if held): the cell's last point takes its place."""
        at = self._where.pop(rid, None)
        if at is None:
            return
        key, i = at
        cell = self._cells[key]
        rids, xy = cell.rids, cell.xy
        last = len(rids) - 1
        if i != last:
            moved = rids[last]
            rids[i] = moved
            xy[2 * i] = xy[2 * last]
            xy[2 * i + 1] = xy[2 * last + 1]
            self._where[moved] = (key, i)
        rids.pop()
        xy.pop()
        xy.pop()
        if not rids:
            del self._cells[key]

    def query(self, minx: float, maxx: float, miny: float, maxy: float) -> tuple[array, np.ndarray]:
        """Return the row ids and (N,2) float64 coordinates [m] of the points in the cells the box [m] meets."""
        c = self.cell
        x0, x1, y0, y1 = minx // c, maxx // c, miny // c, maxy // c
        cells = self._cells
        rids = array("q")
        xy = array("d")
        if (x1 - x0 + 1.0) * (y1 - y0 + 1.0) <= len(cells):
            get = cells.get
            for ix in range(int(x0), int(x1) + 1):
                for iy in range(int(y0), int(y1) + 1):
                    cell = get((ix, iy))
                    if cell is not None:
                        rids.extend(cell.rids)
                        xy.extend(cell.xy)
        else:
            for (ix, iy), cell in cells.items():
                if x0 <= ix <= x1 and y0 <= iy <= y1:
                    rids.extend(cell.rids)
                    xy.extend(cell.xy)
        return rids, np.frombuffer(xy, dtype=np.float64).reshape(-1, 2)
