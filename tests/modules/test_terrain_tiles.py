"""The `terrain_tile` token: heights, sigmas and inadmissible cells survive the encoding; a wrong payload is refused."""

from __future__ import annotations

import base64

import numpy as np
import pydantic
import pytest

from blackboard.registry import default_registry
from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.inadmissible_cells import inadmissible_cells
from modules.terrain.pyramid import TerrainPyramid
from modules.terrain.terrain_map import TerrainMap, TileIndex
from modules.terrain.vehicle_model import NAVLAB_TERRAIN
from modules.vocabulary import TerrainTile

pytestmark = pytest.mark.timeout(120)  # quiet run ~1 s each (the pyramid's numba code from its cache)


def _scene(rng: np.random.Generator, ny: int = 50, nx: int = 70) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    z = rng.normal(0.0, 0.5, (ny, nx)) + 120.0  # heights far from 0: an offset lost in coding would show
    z[5:9, 10:30] = np.nan
    sigma = rng.uniform(0.002, 0.3, (ny, nx))
    sigma[5:9, 10:30] = np.inf
    bad = rng.random((ny, nx)) < 0.2
    return z, sigma, bad


def test_a_tile_round_trips_heights_to_the_centimetre_and_keeps_unknown_and_inadmissible_cells() -> None:
    z, sigma, bad = _scene(np.random.default_rng(3))
    tile = TerrainTile.encode(-40, 17, 0.2, z, sigma, bad, 12.5)
    back = TerrainTile.model_validate_json(tile.model_dump_json())
    zb, sb = back.heights()
    assert zb.dtype == np.float32 and zb.shape == z.shape
    assert np.array_equal(np.isnan(zb), np.isnan(z))
    known = ~np.isnan(z)
    assert np.max(np.abs(zb[known] - z[known])) <= 0.005 + 1e-4
    assert np.max(np.abs(sb[known] - sigma[known])) <= 0.0005 + 1e-6
    assert np.isinf(sb[~known]).all()
    assert np.array_equal(back.inadmissible_mask(), bad)
    assert back.origin == pytest.approx((17 * 0.2, -40 * 0.2))


def test_the_blackboard_knows_the_terrain_tile_type() -> None:
    assert default_registry.model("terrain_tile") is TerrainTile


@pytest.mark.parametrize("field, payload, why", [
    ("z_cm", base64.b64encode(b"\x00" * 10).decode(), "z_cm holds 10 bytes"),
    ("inadmissible", base64.b64encode(b"\x00" * 5).decode(), "inadmissible holds 5 bytes, a 4×6 tile needs 3"),
    ("sigma_mm", "not base64!", "sigma_mm is not base64"),
])
def test_a_payload_of_the_wrong_size_or_not_base64_is_refused_naming_the_field(field: str, payload: str, why: str) -> None:
    z, sigma, bad = _scene(np.random.default_rng(4), 4, 6)
    good = TerrainTile.encode(0, 0, 0.2, z, sigma, bad, 0.0).model_dump()
    with pytest.raises(pydantic.ValidationError, match=why):
        TerrainTile.model_validate({**good, field: payload})


def test_a_map_rebuilt_from_its_tiles_has_the_same_heights_pyramid_and_inadmissible_cells() -> None:
    rng = np.random.default_rng(7)
    bounds = (-3.1, 4.9, 20.3, 17.7)
    src = TerrainMap(bounds, 0.2, NAVLAB_TERRAIN, tile_cells=32)
    ny, nx = src.spec.shape
    Y, X = np.mgrid[0:ny, 0:nx] * 0.2
    z = (0.05 * X + rng.normal(0.0, 0.01, (ny, nx))).astype(np.float32)
    z[20:40, 50:54] += 0.9  # a step no wheel of the Navlab climbs
    z[:, 100:] = np.nan  # never seen
    src.grid.z[:] = z
    src.grid.sigma[:] = np.where(np.isnan(z), np.inf, 0.02)
    src.pyramid.update(src.grid, 0, ny, 0, nx)
    tiles = src.tiles([TileIndex(ti, tj) for ti in range((ny + 31) // 32) for tj in range((nx + 31) // 32)], 3.0)
    assert len(tiles) == ((ny + 31) // 32) * ((nx + 31) // 32)
    dst = TerrainMap(bounds, 0.2, NAVLAB_TERRAIN, tile_cells=32)
    assert all(dst.paste(TerrainTile.model_validate_json(t.model_dump_json())) for t in tiles)
    known = ~np.isnan(z)
    assert np.array_equal(dst.grid.known, known)
    assert np.max(np.abs(dst.grid.z[known] - z[known])) <= 0.0051
    step = inadmissible_cells(dst.pyramid, NAVLAB_TERRAIN)
    assert step[25, 49] and step[25, 54] and not step[25, 30]
    assert np.array_equal(step, inadmissible_cells(src.pyramid, NAVLAB_TERRAIN))
    elsewhere = TerrainMap((100.0, 100.0, 110.0, 110.0), 0.2, NAVLAB_TERRAIN)
    assert not elsewhere.paste(tiles[0])  # a tile outside the map is refused, not wrapped


def test_inadmissible_cells_follow_the_vehicle_s_limits_on_a_known_slope_and_step() -> None:
    y, x = np.mgrid[0:30, 0:60] * 0.2
    z = np.where(x < 6.0, 0.1 * x, 0.9 * x - 4.8).astype(np.float32)  # 5.7° then 42°: beyond the Navlab's tip-over limits
    z[10:20, 20] += 0.6
    grid = ElevationGrid(0.0, 0.0, 0.2, z, np.full_like(z, 0.01))
    bad = inadmissible_cells(TerrainPyramid(grid), NAVLAB_TERRAIN)
    assert not bad[:, 2:18].any() and not bad[:5, :19].any()
    assert bad[15, 19] or bad[15, 20]
    assert bad[:, 32:].all()
