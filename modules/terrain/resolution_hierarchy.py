"""The parameter resolution hierarchy (Navlab 1990 §2.4): voxels of (x, y, θ) classified whole, refined only when mixed.

Voxel level 0 (the finest) has the pyramid's nodes of level `leaf_level` as its squares and
`headings` heading intervals; each level up doubles the square (the pyramid's next level) and halves
the number of intervals (down to one, the whole circle). A configuration is classified by walking
down from the coarsest voxel holding it: a voxel is evaluated once (`constraints.voxel_bounds`, from
pyramid nodes only — one *terrain query*), cached, and if admissible or inadmissible that is the
answer for every configuration in it; only a mixed voxel sends the walk one level down. Below a mixed
level-0 voxel the configuration itself is bounded — the small voxel of the poses the robot may
really take there (the path's sampling step and the control uncertainty: the paper's voxel
expansion) — uncached; mixed there too, the configuration is checked cell by cell at the pixel
resolution (`constraints.configuration_bits`) at its centre and at the corners of that small voxel,
and refused if any of them fails. (The bounds alone refused every motion on real laser maps of
gently rolling ground, where the exact check finds the body 5 cm over it.)

Every voxel is grown by that same expansion (`margin_xy`, `margin_theta`) before it is bounded, so
a path whose samples all lie in admissible voxels is admissible between its samples as well.
Frames: configurations in the pyramid's frame; compiled code takes x, y relative to its origin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from modules.terrain.constraints import (ADMISSIBLE, B_SENSING, INADMISSIBLE, MIXED, Constraint, VehicleArrays,
                                         configuration_bits, constraints_in, voxel_bounds)
from modules.terrain.errors import TerrainError
from modules.terrain.pyramid import TerrainPyramid
from modules.terrain.vehicle_model import TerrainVehicle

__all__ = ["ResolutionHierarchy", "LevelCounts", "classify_pose", "cached_level", "POSE_LEVEL", "NOT_CACHED"]

#: The level reported for a configuration decided by bounding its own small voxel (below level 0).
POSE_LEVEL = -1
#: What `cached_level` returns when a voxel on the way down was never classified.
NOT_CACHED = -2
# counts[]: node reads, voxel queries, pose queries, cache entries written (listed in `touched`), then
# (admissible, inadmissible, mixed) per level, the configurations themselves last.
C_NODES, C_VOXELS, C_POSES, C_TOUCHED, C_LEVELS = 0, 1, 2, 3, 4
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class LevelCounts:
    """How many voxels of one level were classified, by class; `size` [m] their side, `headings` their intervals."""

    level: int
    size: float
    headings: int
    admissible: int
    inadmissible: int
    mixed: int


class ResolutionHierarchy:
    """The voxel hierarchy over one pyramid for one vehicle, with its cache of classified voxels and its counters."""

    def __init__(self, pyramid: TerrainPyramid, vehicle: TerrainVehicle, leaf_voxel: float, levels: int, headings: int,
                 margin_xy: float, margin_theta: float, max_unknown_share: float = 0.0, cover: float = 3.0) -> None:
        """Set up an empty cache: `leaf_voxel` [m] the finest square (rounded to a pyramid level), `levels` voxel levels,
        `headings` intervals at level 0 (a power of two), margins [m], [rad] the voxel expansion."""
        if headings < 1 or headings & (headings - 1):
            raise TerrainError(f"headings must be a power of two, not {headings}")
        if levels < 1:
            raise TerrainError(f"the hierarchy needs at least one level, not {levels}")
        self.pyramid = pyramid
        self.vehicle = vehicle
        self.arrays = VehicleArrays.of(vehicle, pyramid.resolution, max_unknown_share, cover)
        leaf = max(0, int(round(math.log2(max(leaf_voxel, pyramid.resolution) / pyramid.resolution))))
        self.leaf_level = min(leaf, pyramid.levels - 1)
        self.levels = max(1, min(levels, pyramid.levels - self.leaf_level))
        self.headings = headings
        self.margins = np.array([margin_xy, margin_theta], np.float64)
        self.meta = np.array([self.leaf_level, self.levels, headings], np.int64)
        sizes = [int(pyramid.dims[self.leaf_level + lv].prod()) * max(1, headings >> lv) for lv in range(self.levels)]
        self.cache_offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        self.cache = np.zeros(int(self.cache_offsets[-1]), np.uint16)
        self.touched = np.empty(int(self.cache_offsets[-1]), np.int64)
        self.counts = np.zeros(C_LEVELS + 3 * (self.levels + 1), np.int64)
        self.scratch = np.empty(8192, np.int64)

    def reset(self) -> None:
        """Forget every classified voxel and zero the counters (after the pyramid changed)."""
        self.cache[self.touched[:self.counts[C_TOUCHED]]] = 0
        self.counts[:] = 0

    def voxel_size(self, level: int) -> float:
        """Return the side [m] of a level's voxels."""
        return self.pyramid.resolution * 2 ** (self.leaf_level + level)

    def classify(self, x: float, y: float, theta: float) -> tuple[int, int, tuple[Constraint, ...]]:
        """Return (ADMISSIBLE / INADMISSIBLE / MIXED, the deciding level, the constraints against) for (x, y [m], θ [rad])."""
        p = self.pyramid
        state, level, mask = classify_pose(
            x - p.origin_x, y - p.origin_y, theta, p.features, p.offsets, p.dims, p.resolution, p.shape[0], p.shape[1],
            self.arrays.wheels, self.arrays.moments, self.arrays.boxes, self.arrays.body, self.arrays.scalars,
            self.meta, self.cache, self.touched, self.cache_offsets, self.margins, self.scratch, self.counts)
        return state, level, constraints_in(mask)

    @property
    def terrain_queries(self) -> int:
        """Return how many voxels (of any level, and single configurations) were classified from the pyramid."""
        return int(self.counts[C_VOXELS] + self.counts[C_POSES])

    @property
    def node_reads(self) -> int:
        """Return how many pyramid nodes those queries read."""
        return int(self.counts[C_NODES])

    def level_counts(self) -> tuple[LevelCounts, ...]:
        """Return the classified voxels per level, coarsest first, then the configurations bounded one by one (level −1)."""
        out = []
        for lv in range(self.levels - 1, -1, -1):
            a, i, m = (int(v) for v in self.counts[C_LEVELS + 3 * lv:C_LEVELS + 3 * lv + 3])
            out.append(LevelCounts(lv, self.voxel_size(lv), max(1, self.headings >> lv), a, i, m))
        a, i, m = (int(v) for v in self.counts[C_LEVELS + 3 * self.levels:C_LEVELS + 3 * self.levels + 3])
        out.append(LevelCounts(POSE_LEVEL, 0.0, 0, a, i, m))
        return tuple(out)

    def heading_slice(self, theta: float) -> np.ndarray:
        """Return the (rows, cols) int8 classes of level-0 squares at heading θ [rad] from what the cache holds (Figure 2.16).

        0: not classified; ADMISSIBLE / INADMISSIBLE: decided at some level; MIXED: still mixed at level 0.
        """
        leaf_h, leaf_w = (int(d) for d in self.pyramid.dims[self.leaf_level])
        out = np.zeros((leaf_h, leaf_w), np.int8)
        for lv in range(self.levels - 1, -1, -1):
            h, w = (int(d) for d in self.pyramid.dims[self.leaf_level + lv])
            nth = max(1, self.headings >> lv)
            t = int(math.floor((theta % _TWO_PI) / (_TWO_PI / nth))) % nth
            start = int(self.cache_offsets[lv]) + t * h * w
            cls = (self.cache[start:start + h * w].reshape(h, w) & 3).astype(np.int8)
            up = np.repeat(np.repeat(cls, 2 ** lv, axis=0), 2 ** lv, axis=1)[:leaf_h, :leaf_w]
            undecided = (out == 0) | (out == MIXED)
            out = np.where(undecided & (up != 0), up, out)
        return out


@njit(cache=True, nogil=True, boundscheck=False, inline="always")
def _voxel_of(x: float, y: float, a: float, lv: int, leaf: int, nth0: int, dims: np.ndarray, res: float, coff: np.ndarray
              ) -> tuple[int, int, int, int, float, float]:
    """Return the cache index, row, column, heading interval, side [m] and interval [rad] of level `lv`'s voxel holding (x, y, a)."""
    k = leaf + lv
    side = res * (1 << k)
    h, w = dims[k, 0], dims[k, 1]
    nth = max(1, nth0 >> lv)
    width = 2.0 * math.pi / nth
    i, j = int(y / side), int(x / side)
    t = min(int(a / width), nth - 1)
    return coff[lv] + (t * h + i) * w + j, i, j, t, side, width


@njit(cache=True, nogil=True, boundscheck=False)
def classify_pose(x: float, y: float, th: float, feat: np.ndarray, offsets: np.ndarray, dims: np.ndarray, res: float,
                  ny: int, nx: int, wheels: np.ndarray, moments: np.ndarray, boxes: np.ndarray, body: np.ndarray,
                  sc: np.ndarray, meta: np.ndarray, cache: np.ndarray, touched: np.ndarray, coff: np.ndarray,
                  margins: np.ndarray, scratch: np.ndarray, counts: np.ndarray) -> tuple[int, int, int]:
    """Classify configuration (x, y [m] from the grid's origin, θ [rad]) down the hierarchy; return (class, level, bits).

    The bits are the constraints that fail (inadmissible) or that no bound could decide (mixed at the
    configuration itself, which the planner refuses). Cache entries: class | fail bits << 2 | mixed bits << 6.
    """
    if not (0.0 <= x < nx * res and 0.0 <= y < ny * res):
        return INADMISSIBLE, meta[1] - 1, B_SENSING
    leaf, nlev, nth0 = meta[0], meta[1], meta[2]
    a = th % (2.0 * math.pi)
    for lv in range(nlev - 1, -1, -1):
        idx, i, j, t, side, width = _voxel_of(x, y, a, lv, leaf, nth0, dims, res, coff)
        code = np.int64(cache[idx])
        if code == 0:
            state, fail, mixed = voxel_bounds(feat, offsets, dims, res, ny, nx, wheels, moments, boxes, body, sc,
                                              (j + 0.5) * side, (i + 0.5) * side, 0.5 * side + margins[0],
                                              (t + 0.5) * width, 0.5 * width + margins[1], scratch, counts)
            code = state | (fail << 2) | (mixed << 6)
            cache[idx] = np.uint16(code)
            touched[counts[C_TOUCHED]] = idx
            counts[C_TOUCHED] += 1
            counts[C_VOXELS] += 1
            counts[C_LEVELS + 3 * lv + state - 1] += 1
        state = code & 3
        if state == ADMISSIBLE:
            return ADMISSIBLE, lv, 0
        if state == INADMISSIBLE:
            return INADMISSIBLE, lv, (code >> 2) & 15
    state, fail, mixed = voxel_bounds(feat, offsets, dims, res, ny, nx, wheels, moments, boxes, body, sc,
                                      x, y, margins[0], a, margins[1], scratch, counts)
    if state == MIXED:
        # The bounds cannot decide even here: check the configuration cell by cell at its centre and at the
        # corners of its small voxel (the paper's last resort, the pixel resolution); any failure refuses it.
        fail = configuration_bits(feat, offsets, dims, res, ny, nx, wheels, boxes, body, sc, x, y, a)
        for cu in (-1.0, 1.0):
            for cv in (-1.0, 1.0):
                fail |= configuration_bits(feat, offsets, dims, res, ny, nx, wheels, boxes, body, sc, x + cu * margins[0],
                                           y + cv * margins[0], a + cu * cv * margins[1])
        state = INADMISSIBLE if fail else ADMISSIBLE
        mixed = 0
    counts[C_POSES] += 1
    counts[C_LEVELS + 3 * nlev + state - 1] += 1
    return state, -1, fail if state == INADMISSIBLE else mixed


@njit(cache=True, nogil=True, boundscheck=False)
def cached_level(x: float, y: float, th: float, dims: np.ndarray, res: float, ny: int, nx: int, meta: np.ndarray,
                 cache: np.ndarray, coff: np.ndarray) -> int:
    """Return the level whose cached voxel decided configuration (x, y [m] from the grid's origin, θ [rad]), from the cache only.

    POSE_LEVEL when every voxel down to level 0 is cached mixed (the configuration was decided by itself),
    NOT_CACHED when a voxel on the way was never classified or the configuration lies off the grid.
    """
    if not (0.0 <= x < nx * res and 0.0 <= y < ny * res):
        return NOT_CACHED
    leaf, nlev, nth0 = meta[0], meta[1], meta[2]
    a = th % (2.0 * math.pi)
    for lv in range(nlev - 1, -1, -1):
        idx = _voxel_of(x, y, a, lv, leaf, nth0, dims, res, coff)[0]
        code = np.int64(cache[idx])
        if code == 0:
            return NOT_CACHED
        if code & 3 != MIXED:
            return lv
    return POSE_LEVEL
