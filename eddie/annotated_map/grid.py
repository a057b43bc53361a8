"""The 0.5 m grid over `world` and the supercover walk of a segment (every cell it touches, not Bresenham)."""

from __future__ import annotations

import math
from typing import Iterator

__all__ = ["Cell", "Grid", "DEFAULT_CELL_M"]

#: The seed's grid resolution [m].
DEFAULT_CELL_M = 0.5

Cell = tuple[int, int]


class Grid:
    """A square grid of `cell` [m] cells over `world`; cell (i, j) spans [i·cell, (i+1)·cell) × [j·cell, (j+1)·cell)."""

    def __init__(self, cell: float = DEFAULT_CELL_M) -> None:
        if not (cell > 0 and math.isfinite(cell)):
            raise ValueError(f"grid cell must be a positive size [m], got {cell}")
        self.cell = float(cell)

    def cell_of(self, x: float, y: float) -> Cell:
        """Return the cell holding (x, y) [m] `world`."""
        return math.floor(x / self.cell), math.floor(y / self.cell)

    def box(self, xmin: float, ymin: float, xmax: float, ymax: float) -> Iterator[Cell]:
        """Yield every cell of the box [m] `world` (inclusive)."""
        i0, j0 = self.cell_of(xmin, ymin)
        i1, j1 = self.cell_of(xmax, ymax)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                yield i, j

    def cell_box(self, c: Cell) -> tuple[float, float, float, float]:
        """Return the box (xmin, ymin, xmax, ymax) [m] `world` of cell `c`."""
        return c[0] * self.cell, c[1] * self.cell, (c[0] + 1) * self.cell, (c[1] + 1) * self.cell

    def supercover(self, x0: float, y0: float, x1: float, y1: float) -> list[Cell]:
        """Return every cell the segment (x0, y0)→(x1, y1) [m] `world` touches, in order (Amanatides–Woo with corner cases)."""
        i, j = self.cell_of(x0, y0)
        ie, je = self.cell_of(x1, y1)
        out = [(i, j)]
        dx, dy = x1 - x0, y1 - y0
        si = 1 if dx > 0 else -1
        sj = 1 if dy > 0 else -1
        c = self.cell
        # parameter t at which the ray crosses the next vertical / horizontal grid line, and per-cell step
        if dx != 0:
            nx = (i + (1 if dx > 0 else 0)) * c
            tx, tdx = (nx - x0) / dx, c / abs(dx)
        else:
            tx = tdx = math.inf
        if dy != 0:
            ny = (j + (1 if dy > 0 else 0)) * c
            ty, tdy = (ny - y0) / dy, c / abs(dy)
        else:
            ty = tdy = math.inf
        n = abs(ie - i) + abs(je - j)
        guard = 0
        while (i, j) != (ie, je) and guard <= n + 2:
            guard += 1
            if abs(tx - ty) < 1e-12:
                # through a corner: both neighbours are touched by the segment's closure
                out.append((i + si, j))
                out.append((i, j + sj))
                i += si
                j += sj
                tx += tdx
                ty += tdy
            elif tx < ty:
                i += si
                tx += tdx
            else:
                j += sj
                ty += tdy
            out.append((i, j))
        return out
