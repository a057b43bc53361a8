"""The terrain pyramid (Navlab 1990 §2.3.3): a quadtree over an elevation grid whose nodes describe their quadrant.

Each node carries what the paper lists — minimum, maximum and mean elevation, maximum slope and
maximum discontinuity — and the share of its cells that are known. Level 0 has one node per grid
cell; a node (i, j) of level k covers the 2^k × 2^k cells of rows i·2^k … and columns j·2^k …
(cells past the grid's edge count as absent, not unknown). Each level is built from the one below by
vectorised 2×2 reductions; `update` rebuilds only the nodes over a changed block of cells.

Slope and discontinuity come from one gradient operator on the grid, per axis: of the backward and
forward height differences beside a cell, the *slope* is their minmod (the smaller when both have
the same sign, else 0) over the cell size, and the *discontinuity* is the part of the larger jump the
slope does not explain (max |difference| − |minmod|). A plane has its slope everywhere and no
discontinuity; a step of height h has slope 0 and discontinuity h in the two cells beside it (so in
the nodes that hold either). A difference with an unknown or absent neighbour is left out.

One feature is added for the cross-country planner, in the paper's spirit ("we only added such
features if the initial overhead ... was less than the computational benefit to the planner"): each
node's least-squares plane through its known cells (height at the node's centre, gradient) and how far
its cells lie above and below that plane. From it the planner bounds a vehicle's pitch, roll and
clearance over a whole node on a slope, where the min/max elevation alone would say nothing.

Frames: the grid's frame (usually `world`); node geometry in [m] relative to the grid's origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import TerrainError

__all__ = ["TerrainPyramid", "PyramidLevel", "TerrainSummary", "FEATURES"]

#: Rows of `TerrainPyramid.features`, one per node feature (the planner's compiled code reads them by index).
FEATURES = ("count", "cells", "zmin", "zmax", "zsum", "slope", "disc",
            "sx", "sy", "sxx", "syy", "sxy", "sxz", "syz", "plane_z", "plane_gx", "plane_gy", "above", "below")
(F_COUNT, F_CELLS, F_ZMIN, F_ZMAX, F_ZSUM, F_SLOPE, F_DISC, F_SX, F_SY, F_SXX, F_SYY, F_SXY, F_SXZ, F_SYZ,
 F_PZ, F_PGX, F_PGY, F_ABOVE, F_BELOW) = range(len(FEATURES))
_SUMMED = (F_COUNT, F_CELLS, F_ZSUM, F_SX, F_SY, F_SXX, F_SYY, F_SXY, F_SXZ, F_SYZ)
_MAXED = (F_ZMAX, F_SLOPE, F_DISC)


@dataclass(frozen=True)
class PyramidLevel:
    """One level's features as (rows, cols) float64 views; NaN where a node holds no known cell.

    `node_size` [m] is the side of a node; `zmin`, `zmax`, `zmean` [m]; `slope` [m/m] the largest
    gradient magnitude; `disc` [m] the largest discontinuity; `known_share` the share of the node's
    cells with a height; `plane_z` [m] the plane's height at the node's centre, `plane_gx`, `plane_gy`
    [m/m] its gradient; `above`, `below` [m] (≥ 0) how far the node's cells rise above and fall below it.
    """

    level: int
    node_size: float
    zmin: np.ndarray
    zmax: np.ndarray
    zmean: np.ndarray
    slope: np.ndarray
    disc: np.ndarray
    known_share: np.ndarray
    plane_z: np.ndarray
    plane_gx: np.ndarray
    plane_gy: np.ndarray
    above: np.ndarray
    below: np.ndarray


@dataclass(frozen=True)
class TerrainSummary:
    """What the pyramid knows of a block of cells: elevation range [m], largest slope [m/m] and discontinuity [m], known share.

    `nodes` is how many pyramid nodes the answer read (the block decomposed into whole quadrants).
    Elevations, slope and discontinuity are NaN when no cell of the block is known.
    """

    zmin: float
    zmax: float
    zmean: float
    slope: float
    disc: float
    known_share: float
    nodes: int


class TerrainPyramid:
    """A quadtree of terrain features over an `ElevationGrid`, built whole by `TerrainPyramid(grid)`, kept by `update`.

    `features` is the (total nodes, len(FEATURES)) float64 array of every level packed one after the
    other; level k's nodes are rows `offsets[k]:offsets[k+1]`, row-major over `dims[k]` = (rows, cols).
    """

    def __init__(self, grid: ElevationGrid) -> None:
        """Build every level of the pyramid of `grid`."""
        ny, nx = grid.shape
        if ny < 1 or nx < 1:
            raise TerrainError(f"a terrain pyramid needs at least one cell, the grid is {ny}×{nx}")
        self.origin_x = float(grid.origin_x)
        self.origin_y = float(grid.origin_y)
        self.resolution = float(grid.resolution)
        self.frame = grid.frame
        self.shape = (ny, nx)
        dims = [(ny, nx)]
        while dims[-1] != (1, 1):
            h, w = dims[-1]
            dims.append(((h + 1) // 2, (w + 1) // 2))
        self.dims = np.array(dims, np.int64)
        self.offsets = np.concatenate([[0], np.cumsum(self.dims[:, 0] * self.dims[:, 1])]).astype(np.int64)
        self.features = np.empty((int(self.offsets[-1]), len(FEATURES)), np.float64)
        self.update(grid, 0, ny, 0, nx)  # sets every entry

    @property
    def levels(self) -> int:
        """Return the number of levels (level 0: the cells; the last: one node over the whole grid)."""
        return int(self.dims.shape[0])

    def _view(self, f: int, k: int) -> np.ndarray:
        h, w = self.dims[k]
        return self.features[self.offsets[k]:self.offsets[k + 1], f].reshape(int(h), int(w))

    def level(self, k: int) -> PyramidLevel:
        """Return level `k`'s features (views into the pyramid: they follow later updates)."""
        if not 0 <= k < self.levels:
            raise TerrainError(f"the pyramid has levels 0..{self.levels - 1}, not {k}")
        v = lambda f: self._view(f, k)  # noqa: E731 - a short local alias
        with np.errstate(invalid="ignore", divide="ignore"):
            known = v(F_COUNT) > 0
            zmean = np.where(known, v(F_ZSUM) / np.maximum(v(F_COUNT), 1.0), np.nan)
            share = v(F_COUNT) / np.maximum(v(F_CELLS), 1.0)
        return PyramidLevel(k, self.resolution * 2 ** k, v(F_ZMIN), v(F_ZMAX), zmean, v(F_SLOPE), v(F_DISC), share,
                            v(F_PZ), v(F_PGX), v(F_PGY), v(F_ABOVE), v(F_BELOW))

    def update(self, grid: ElevationGrid, row0: int, row1: int, col0: int, col1: int) -> None:
        """Recompute every node over cells [row0, row1) × [col0, col1) after those cells of `grid` changed."""
        if grid.shape != self.shape or grid.resolution != self.resolution or (grid.origin_x, grid.origin_y) != (
                self.origin_x, self.origin_y):
            raise TerrainError(f"the grid ({grid.shape}, {grid.resolution} m at {grid.origin_x}, {grid.origin_y}) is not "
                               f"the one this pyramid was built on ({self.shape}, {self.resolution} m at "
                               f"{self.origin_x}, {self.origin_y})")
        ny, nx = self.shape
        row0, col0 = max(0, int(row0)), max(0, int(col0))
        row1, col1 = min(ny, int(row1)), min(nx, int(col1))
        if row0 >= row1 or col0 >= col1:
            return
        z = grid.z if grid.z.dtype == np.float32 and grid.z.flags.c_contiguous else np.ascontiguousarray(grid.z, np.float32)
        # Slope and discontinuity read the neighbours: the ring of cells around the block changes too.
        r0, r1, c0, c1 = max(0, row0 - 1), min(ny, row1 + 1), max(0, col0 - 1), min(nx, col1 + 1)
        _cells(z, self.features, self.resolution, r0, r1, c0, c1)
        for k in range(1, self.levels):
            r0, r1, c0, c1 = r0 // 2, (r1 + 1) // 2, c0 // 2, (c1 + 1) // 2
            _reduce(z, self.features, self.offsets, self.dims, k, self.resolution, ny, nx, r0, r1, c0, c1)

    def summary(self, row0: int, row1: int, col0: int, col1: int) -> TerrainSummary:
        """Return the features of cells [row0, row1) × [col0, col1), read from the fewest whole quadrants."""
        ny, nx = self.shape
        row0, col0, row1, col1 = max(0, row0), max(0, col0), min(ny, row1), min(nx, col1)
        if row0 >= row1 or col0 >= col1:
            raise TerrainError(f"cells [{row0}, {row1}) × [{col0}, {col1}) hold no cell of the {ny}×{nx} grid")
        nodes: list[tuple[int, int]] = []  # (level, flat index)
        self._decompose(self.levels - 1, 0, 0, row0, row1, col0, col1, nodes)
        idx = np.array([int(self.offsets[k]) + i for k, i in nodes])
        f = self.features[idx].T
        count, cells = f[F_COUNT].sum(), f[F_CELLS].sum()
        with np.errstate(invalid="ignore"):
            zmean = f[F_ZSUM].sum() / count if count else np.nan
        nan_or = lambda fn, a: float(fn(a)) if count else float("nan")  # noqa: E731 - a short local alias
        return TerrainSummary(nan_or(np.nanmin, f[F_ZMIN]), nan_or(np.nanmax, f[F_ZMAX]), float(zmean),
                              nan_or(np.nanmax, f[F_SLOPE]), nan_or(np.nanmax, f[F_DISC]), float(count / cells), len(nodes))

    def _decompose(self, k: int, i: int, j: int, row0: int, row1: int, col0: int, col1: int,
                   out: list[tuple[int, int]]) -> None:
        b = 2 ** k
        h, w = (int(d) for d in self.dims[k])
        if i >= h or j >= w:
            return
        nr0, nr1, nc0, nc1 = i * b, (i + 1) * b, j * b, (j + 1) * b
        if nr1 <= row0 or nr0 >= row1 or nc1 <= col0 or nc0 >= col1:
            return
        ny, nx = self.shape
        if row0 <= nr0 and min(nr1, ny) <= row1 and col0 <= nc0 and min(nc1, nx) <= col1:
            out.append((k, i * w + j))
            return
        for di in (0, 1):
            for dj in (0, 1):
                self._decompose(k - 1, 2 * i + di, 2 * j + dj, row0, row1, col0, col1, out)


@njit(cache=True, nogil=True, boundscheck=False)
def _minmod_and_jump(back: float, fwd: float) -> tuple[float, float]:
    """Return (slope, discontinuity) [m] from a cell's backward and forward height differences (NaN: missing).

    slope: their minmod (the one alone when the other is missing, 0 when both are); discontinuity:
    max |difference| − |slope|, 0 unless both differences exist.
    """
    if back != back:
        return (0.0 if fwd != fwd else fwd), 0.0
    if fwd != fwd:
        return back, 0.0
    if back * fwd <= 0.0:
        mm = 0.0
    elif abs(back) < abs(fwd):
        mm = back
    else:
        mm = fwd
    return mm, max(abs(back), abs(fwd)) - abs(mm)


@njit(cache=True, nogil=True, boundscheck=False)
def _cells(z: np.ndarray, feat: np.ndarray, res: float, r0: int, r1: int, c0: int, c1: int) -> None:
    """Set level 0 (the first ny·nx rows of `feat`) over cells [r0, r1) × [c0, c1) of (ny, nx) float32 heights `z`."""
    ny, nx = z.shape
    nan = np.nan
    for i in range(r0, r1):
        y = (i + 0.5) * res
        for j in range(c0, c1):
            n = i * nx + j
            h = np.float64(z[i, j])
            feat[n, F_CELLS] = 1.0
            feat[n, F_ZMIN] = h
            feat[n, F_ZMAX] = h
            feat[n, F_PZ] = h
            if h != h:
                for f in (F_COUNT, F_ZSUM, F_SX, F_SY, F_SXX, F_SYY, F_SXY, F_SXZ, F_SYZ):
                    feat[n, f] = 0.0
                for f in (F_SLOPE, F_DISC, F_PGX, F_PGY, F_ABOVE, F_BELOW):
                    feat[n, f] = nan
                continue
            x = (j + 0.5) * res
            feat[n, F_COUNT] = 1.0
            feat[n, F_ZSUM] = h
            feat[n, F_SX] = x
            feat[n, F_SY] = y
            feat[n, F_SXX] = x * x
            feat[n, F_SYY] = y * y
            feat[n, F_SXY] = x * y
            feat[n, F_SXZ] = x * h
            feat[n, F_SYZ] = y * h
            feat[n, F_PGX] = 0.0
            feat[n, F_PGY] = 0.0
            feat[n, F_ABOVE] = 0.0
            feat[n, F_BELOW] = 0.0
            bx = h - z[i, j - 1] if j > 0 else nan
            fx = z[i, j + 1] - h if j + 1 < nx else nan
            by = h - z[i - 1, j] if i > 0 else nan
            fy = z[i + 1, j] - h if i + 1 < ny else nan
            sx, dx = _minmod_and_jump(bx, fx)
            sy, dy = _minmod_and_jump(by, fy)
            feat[n, F_SLOPE] = np.sqrt(sx * sx + sy * sy) / res
            feat[n, F_DISC] = max(dx, dy)


@njit(cache=True, nogil=True, boundscheck=False)
def _reduce(z: np.ndarray, feat: np.ndarray, offsets: np.ndarray, dims: np.ndarray, k: int, res: float, ny: int, nx: int,
            r0: int, r1: int, c0: int, c1: int) -> None:
    """Set level-k nodes [r0, r1) × [c0, c1) of `feat` from their (up to four) children on level k − 1.

    Sums and extremes reduce 2×2; the plane is the least-squares one of the node's known cells (from
    the summed moments); `above`/`below` are measured on the node's cells of the (ny, nx) float32 `z`.
    """
    nan = np.nan
    h, w = dims[k, 0], dims[k, 1]
    ch, cw = dims[k - 1, 0], dims[k - 1, 1]
    off, coff = offsets[k], offsets[k - 1]
    r1 = min(r1, h)
    c1 = min(c1, w)
    b = 1 << k
    size = b * res
    for i in range(r0, r1):
        for j in range(c0, c1):
            n = off + i * w + j
            cnt = cells = zsum = sx = sy = sxx = syy = sxy = sxz = syz = 0.0
            zmin = zmax = slope = disc = nan
            for di in range(2):
                ci = 2 * i + di
                if ci >= ch:
                    continue
                for dj in range(2):
                    cj = 2 * j + dj
                    if cj >= cw:
                        continue
                    m = coff + ci * cw + cj
                    cells += feat[m, F_CELLS]
                    if feat[m, F_COUNT] == 0.0:
                        continue
                    cnt += feat[m, F_COUNT]
                    zsum += feat[m, F_ZSUM]
                    sx += feat[m, F_SX]
                    sy += feat[m, F_SY]
                    sxx += feat[m, F_SXX]
                    syy += feat[m, F_SYY]
                    sxy += feat[m, F_SXY]
                    sxz += feat[m, F_SXZ]
                    syz += feat[m, F_SYZ]
                    zmin = feat[m, F_ZMIN] if not zmin <= feat[m, F_ZMIN] else zmin
                    zmax = feat[m, F_ZMAX] if not zmax >= feat[m, F_ZMAX] else zmax
                    v = feat[m, F_SLOPE]
                    slope = v if not slope >= v else slope
                    v = feat[m, F_DISC]
                    disc = v if not disc >= v else disc
            feat[n, F_COUNT] = cnt
            feat[n, F_CELLS] = cells
            feat[n, F_ZSUM] = zsum
            feat[n, F_SX] = sx
            feat[n, F_SY] = sy
            feat[n, F_SXX] = sxx
            feat[n, F_SYY] = syy
            feat[n, F_SXY] = sxy
            feat[n, F_SXZ] = sxz
            feat[n, F_SYZ] = syz
            feat[n, F_ZMIN] = zmin
            feat[n, F_ZMAX] = zmax
            feat[n, F_SLOPE] = slope
            feat[n, F_DISC] = disc
            if cnt == 0.0:
                for f in (F_PZ, F_PGX, F_PGY, F_ABOVE, F_BELOW):
                    feat[n, f] = nan
                continue
            mx, my, mz = sx / cnt, sy / cnt, zsum / cnt
            cxx, cyy, cxy = sxx / cnt - mx * mx, syy / cnt - my * my, sxy / cnt - mx * my
            cxz, cyz = sxz / cnt - mx * mz, syz / cnt - my * mz
            det = cxx * cyy - cxy * cxy
            gx = gy = 0.0
            # Cells all on one row or column fix the slope along it only; one cell fixes none.
            if cnt >= 3.0 and det > 1e-9 * res ** 4:
                gx = (cyy * cxz - cxy * cyz) / det
                gy = (cxx * cyz - cxy * cxz) / det
            elif cxx > 1e-9 * res ** 2 and cyy <= 1e-9 * res ** 2:
                gx = cxz / cxx
            elif cyy > 1e-9 * res ** 2 and cxx <= 1e-9 * res ** 2:
                gy = cyz / cyy
            xc, yc = (j + 0.5) * size, (i + 0.5) * size
            pz = mz + gx * (xc - mx) + gy * (yc - my)
            above = below = 0.0
            for ii in range(i * b, min((i + 1) * b, ny)):
                dy = (ii + 0.5) * res - yc
                for jj in range(j * b, min((j + 1) * b, nx)):
                    zz = z[ii, jj]
                    if zz != zz:
                        continue
                    dd = zz - (pz + gx * ((jj + 0.5) * res - xc) + gy * dy)
                    above = max(above, dd)
                    below = max(below, -dd)
            feat[n, F_PZ] = pz
            feat[n, F_PGX] = gx
            feat[n, F_PGY] = gy
            feat[n, F_ABOVE] = above
            feat[n, F_BELOW] = below
