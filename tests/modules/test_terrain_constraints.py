"""The planner's constraints (Navlab 1990 §2.4, Figure 2.15): one configuration on known terrain, and whole voxels held to brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.terrain.constraints import (ADMISSIBLE, INADMISSIBLE, Constraint, VehicleArrays, constraints_in,
                                         evaluate_configuration, voxel_bounds)
from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.pyramid import TerrainPyramid
from modules.terrain.vehicle_model import NAVLAB_TERRAIN, TERREGATOR_TERRAIN, TerrainVehicle
from tests.modules._terrain_check import discontinuity, violations

pytestmark = pytest.mark.timeout(180)  # runs ≤ 12 s each (busy machine) with numba's cache warm; compiling the bounds ~40 s

RES = 0.1


def _scene(z: np.ndarray) -> tuple[ElevationGrid, TerrainPyramid]:
    z = z.astype(np.float32)
    grid = ElevationGrid(-10.0, -10.0, RES, z, np.full_like(z, 0.02))
    return grid, TerrainPyramid(grid)


def _xy(n: int = 200) -> tuple[np.ndarray, np.ndarray]:
    y, x = (np.mgrid[0:n, 0:n] + 0.5) * RES - 10.0
    return x, y


@pytest.mark.parametrize("slope, tips", [(0.30, False), (0.40, True)])
def test_roll_on_a_cross_slope_is_the_slopes_angle(slope, tips):
    x, y = _xy()
    grid, pyr = _scene(slope * y)  # rising to the vehicle's left when it heads along +x
    v = evaluate_configuration(grid, pyr, NAVLAB_TERRAIN, 0.0, 0.0, 0.0)
    # A wheel stands on the highest cell centre in its patch: the contacts move by up to one cell across the track.
    track, base = 1.75, 3.7
    assert v.roll == pytest.approx(math.atan(slope), abs=slope * RES / track)
    assert v.pitch == pytest.approx(0.0, abs=1e-3)
    assert (Constraint.TIP_OVER in v.violated) is tips  # the Navlab's limit: 20° (tan = 0.364)
    turned = evaluate_configuration(grid, pyr, NAVLAB_TERRAIN, 0.0, 0.0, math.pi / 2)  # now it climbs: 25° allowed
    assert turned.pitch == pytest.approx(math.atan(slope), abs=slope * RES / base) and turned.admissible


@pytest.mark.parametrize("where, u, kind", [
    ("belly", 0.0, Constraint.HIGH_CENTRING),
    ("front bumper", 2.4, Constraint.COLLISION),
])
def test_a_box_under_the_body_high_centres_or_collides(where, u, kind):
    x, y = _xy()
    box = (np.abs(x - u) < 0.25) & (np.abs(y) < 0.25)
    low, high = _scene(np.where(box, 0.15, 0.0)), _scene(np.where(box, 0.45, 0.0))
    assert evaluate_configuration(*low, NAVLAB_TERRAIN, 0.0, 0.0, 0.0).admissible  # under both clearances
    v = evaluate_configuration(*high, NAVLAB_TERRAIN, 0.0, 0.0, 0.0)
    assert v.violated == (kind,), where


def test_a_wheel_on_a_step_it_cannot_climb_collides():
    x, y = _xy()
    wu, wv = NAVLAB_TERRAIN.wheels[0]
    grid, pyr = _scene(np.where(x > wu, 0.3, 0.0))  # the front wheels stand at the step's foot
    v = evaluate_configuration(grid, pyr, NAVLAB_TERRAIN, 0.0, 0.0, 0.0)
    assert Constraint.COLLISION in v.violated and v.wheel_step == pytest.approx(0.3, abs=1e-5)
    small, spyr = _scene(np.where(x > wu, 0.1, 0.0))
    assert evaluate_configuration(small, spyr, NAVLAB_TERRAIN, 0.0, 0.0, 0.0).wheel_step == pytest.approx(0.1, abs=1e-5)


def test_unknown_terrain_under_the_body_violates_sensing_unless_allowed():
    x, y = _xy()
    z = np.zeros(x.shape)
    z[(np.abs(x) < 0.3) & (np.abs(y) < 0.3)] = np.nan  # 36 cells under the belly
    grid, pyr = _scene(z)
    assert evaluate_configuration(grid, pyr, NAVLAB_TERRAIN, 0.0, 0.0, 0.0).violated == (Constraint.SENSING,)
    assert evaluate_configuration(grid, pyr, NAVLAB_TERRAIN, 0.0, 0.0, 0.0, max_unknown_share=0.05).admissible


def test_the_library_check_agrees_with_brute_force():
    rng = np.random.default_rng(11)
    x, y = _xy()
    z = 0.15 * x + 0.3 * np.sin(0.4 * y) + rng.normal(0.0, 0.02, x.shape)
    for _ in range(12):
        cx, cy = rng.uniform(-9, 9, 2)
        z += np.where(np.hypot(x - cx, y - cy) < rng.uniform(0.2, 0.8), rng.uniform(0.1, 0.6), 0.0)
    grid, pyr = _scene(z)
    disc = discontinuity(grid.z)
    for _ in range(60):
        px, py, th = *rng.uniform(-6, 6, 2), rng.uniform(-math.pi, math.pi)
        lib = {c.value for c in evaluate_configuration(grid, pyr, NAVLAB_TERRAIN, px, py, th).violated}
        assert lib == violations(grid, disc, NAVLAB_TERRAIN, px, py, th), (px, py, th)


def _rough(seed: int, rocks: int = 15, hill: float = 1.5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x, y = _xy()
    z = 0.12 * x - 0.08 * y + hill * np.exp(-((x - 3) ** 2 + (y + 2) ** 2) / 30.0) + rng.normal(0.0, 0.01, x.shape)
    for _ in range(rocks):
        cx, cy = rng.uniform(-9, 9, 2)
        z += np.where(np.hypot(x - cx, y - cy) < rng.uniform(0.2, 0.9), rng.uniform(0.1, 0.7), 0.0)
    z[np.hypot(x + 6, y - 6) < 1.0] = np.nan
    return z


@pytest.mark.parametrize("vehicle", [NAVLAB_TERRAIN, TERREGATOR_TERRAIN], ids=lambda v: v.name)
def test_a_voxel_called_admissible_or_inadmissible_is_so_for_every_configuration_in_it(vehicle: TerrainVehicle):
    rng = np.random.default_rng(2)
    # Rough ground (the Navlab's 5.6 m body finds few voxels free of its 15 rocks and its hill's crest), gentle
    # ground (three rocks, no hill), and a 39° slope, beyond either vehicle's limits whichever way it heads.
    scenes = [_scene(_rough(4)), _scene(_rough(5, rocks=3, hill=0.0)), _scene(0.8 * _xy()[0])]
    decided = {ADMISSIBLE: 0, INADMISSIBLE: 0}
    for g, p in [scenes[0]] * 3 + [scenes[1]] * 2 + [scenes[2]]:
        d = discontinuity(g.z)
        a = VehicleArrays.of(vehicle, RES, 0.0)
        scratch, counts = np.empty(8192, np.int64), np.zeros(4, np.int64)
        for _ in range(40):
            h, hth = rng.choice([0.1, 0.2, 0.4, 0.8]), rng.choice([0.03, 0.1, 0.3, math.pi])
            xc, yc, th = *rng.uniform(-5, 5, 2), rng.uniform(-math.pi, math.pi)
            state, fail, _ = voxel_bounds(p.features, p.offsets, p.dims, RES, *g.shape, a.wheels, a.moments, a.boxes,
                                          a.body, a.scalars, xc + 10.0, yc + 10.0, h, th, hth, scratch, counts)
            if state not in decided:
                continue
            decided[state] += 1
            for _ in range(8):
                px, py = xc + rng.uniform(-h, h), yc + rng.uniform(-h, h)
                found = violations(g, d, vehicle, px, py, th + rng.uniform(-hth, hth))
                if state == ADMISSIBLE:
                    assert not found, (xc, yc, h, th, hth, found)
                else:
                    assert {c.value for c in constraints_in(fail)} <= found, (xc, yc, h, th, hth, found)
    assert decided[ADMISSIBLE] >= 10 and decided[INADMISSIBLE] >= 10  # both kinds of verdict were put to the test
