"""The terrain pyramid (Navlab 1990 §2.3.3): known features of a plane and a step, every node against its cells, updates."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import TerrainError
from modules.terrain.pyramid import TerrainPyramid

pytestmark = pytest.mark.timeout(120)  # quiet run ~3 s each after the first compile (~40 s)


def _grid(z: np.ndarray, res: float = 0.1) -> ElevationGrid:
    z = z.astype(np.float32)
    return ElevationGrid(2.0, -3.0, res, z, np.where(np.isnan(z), np.inf, 0.02).astype(np.float32))


def _blocks(a: np.ndarray, k: int) -> list[list[np.ndarray]]:
    b = 2 ** k
    return [[a[i:i + b, j:j + b] for j in range(0, a.shape[1], b)] for i in range(0, a.shape[0], b)]


def test_a_plane_has_its_slope_everywhere_and_no_discontinuity():
    ny, nx, res = 45, 70, 0.1
    y, x = (np.mgrid[0:ny, 0:nx] + 0.5) * res
    gx, gy = 0.3, -0.2
    pyr = TerrainPyramid(_grid(1.0 + gx * x + gy * y, res))
    for k in range(pyr.levels):
        lv = pyr.level(k)
        assert np.allclose(lv.slope, math.hypot(gx, gy), atol=1e-4), k
        assert np.nanmax(lv.disc) < 1e-5, k
        assert np.nanmax(lv.above) < 1e-5 and np.nanmax(lv.below) < 1e-5, k
        if k > 0:  # nodes wholly on the grid (one cell, or one row, fixes no full gradient)
            full = (slice(0, ny // 2 ** k), slice(0, nx // 2 ** k))
            assert np.allclose(lv.plane_gx[full], gx, atol=1e-4) and np.allclose(lv.plane_gy[full], gy, atol=1e-4), k
        assert np.all(lv.known_share == 1.0)


@pytest.mark.parametrize("col", [31, 33])  # the step on a node boundary at every level up to 5, and inside level-1+ nodes
def test_a_step_shows_its_height_as_discontinuity_only_in_the_nodes_beside_it(col):
    ny, nx, h = 40, 64, 0.45
    z = np.where(np.arange(nx)[None, :] > col, h, 0.0) * np.ones((ny, 1))
    pyr = TerrainPyramid(_grid(z))
    for k in range(pyr.levels):
        disc = pyr.level(k).disc
        b = 2 ** k
        beside = {col // b, (col + 1) // b}  # the node columns holding a cell next to the step
        for j in range(disc.shape[1]):
            want = h if j in beside else 0.0
            assert np.allclose(disc[:, j], want, atol=1e-5), (k, j, disc[0, j])
        assert np.allclose(pyr.level(k).slope, 0.0, atol=1e-5)  # the step is no slope


def test_every_node_holds_the_features_of_its_cells():
    rng = np.random.default_rng(7)
    ny, nx, res = 37, 53, 0.2  # odd sizes: the last nodes are partial
    z = rng.normal(0.0, 0.3, (ny, nx)) + np.linspace(0.0, 2.0, nx)[None, :]
    z[rng.random((ny, nx)) < 0.15] = np.nan
    z[:8, :8] = np.nan  # a block with no known cell
    grid = _grid(z, res)
    pyr = TerrainPyramid(grid)
    zz = grid.z.astype(np.float64)
    lv0 = pyr.level(0)
    for k in range(1, pyr.levels):
        lv = pyr.level(k)
        zb, sb, db = _blocks(zz, k), _blocks(lv0.slope, k), _blocks(lv0.disc, k)
        for i, row in enumerate(zb):
            for j, cells in enumerate(row):
                known = ~np.isnan(cells)
                assert lv.known_share[i, j] == pytest.approx(known.mean())
                if not known.any():
                    assert np.isnan(lv.zmin[i, j]) and np.isnan(lv.zmax[i, j]) and np.isnan(lv.zmean[i, j])
                    continue
                assert lv.zmin[i, j] == pytest.approx(np.nanmin(cells))
                assert lv.zmax[i, j] == pytest.approx(np.nanmax(cells))
                assert lv.zmean[i, j] == pytest.approx(np.nanmean(cells))
                assert lv.slope[i, j] == pytest.approx(np.nanmax(sb[i][j]))
                assert lv.disc[i, j] == pytest.approx(np.nanmax(db[i][j]))
                b = 2 ** k
                ci, cj = np.nonzero(known)
                cx, cy = (j * b + cj + 0.5) * res, (i * b + ci + 0.5) * res
                plane = lv.plane_z[i, j] + lv.plane_gx[i, j] * (cx - (j + 0.5) * b * res) \
                    + lv.plane_gy[i, j] * (cy - (i + 0.5) * b * res)
                d = cells[known] - plane
                assert lv.above[i, j] == pytest.approx(max(0.0, d.max()), abs=1e-6)
                assert lv.below[i, j] == pytest.approx(max(0.0, -d.min()), abs=1e-6)
                if known.sum() >= 3 and len(set(ci)) > 1 and len(set(cj)) > 1:
                    a = np.column_stack([np.ones(len(cx)), cx, cy])
                    coef = np.linalg.lstsq(a, cells[known], rcond=None)[0]
                    assert lv.plane_gx[i, j] == pytest.approx(coef[1], abs=1e-6)
                    assert lv.plane_gy[i, j] == pytest.approx(coef[2], abs=1e-6)


def test_an_update_of_a_block_gives_what_a_full_build_gives():
    rng = np.random.default_rng(3)
    z = rng.normal(0.0, 0.2, (90, 75))
    grid = _grid(z)
    pyr = TerrainPyramid(grid)
    grid.z[40:61, 10:33] += 0.7  # the map fused a new image over these cells
    grid.z[45:50, 12:15] = np.nan
    pyr.update(grid, 40, 61, 10, 33)
    fresh = TerrainPyramid(grid)
    assert np.allclose(pyr.features, fresh.features, equal_nan=True, atol=1e-9)


def test_a_summary_reads_whole_quadrants_and_matches_the_cells():
    rng = np.random.default_rng(5)
    z = rng.normal(0.0, 0.5, (64, 64))
    pyr = TerrainPyramid(_grid(z))
    s = pyr.summary(5, 50, 3, 61)
    block = z[5:50, 3:61].astype(np.float32)
    assert s.zmin == pytest.approx(block.min()) and s.zmax == pytest.approx(block.max())
    assert s.zmean == pytest.approx(block.mean(), rel=1e-5)
    assert s.known_share == 1.0
    assert s.nodes < block.size / 10


def test_a_grid_other_than_the_pyramids_is_refused():
    pyr = TerrainPyramid(_grid(np.zeros((10, 10))))
    with pytest.raises(TerrainError, match="not the one this pyramid was built on"):
        pyr.update(_grid(np.zeros((10, 12))), 0, 10, 0, 10)
    with pytest.raises(TerrainError, match="levels 0"):
        pyr.level(9)
