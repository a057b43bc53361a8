"""The cross-country planner (Navlab 1990 §2.4): paths around obstacles held to brute force, typed refusals, kinematics, the hierarchy's savings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.terrain.constraints import ADMISSIBLE, MIXED, Constraint
from modules.terrain.cross_country_planner import CrossCountryPlan, CrossCountryPlanner, CrossCountrySettings
from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import InadmissibleGoal, InadmissibleStart, NoAdmissiblePath
from modules.terrain.pyramid import TerrainPyramid
from modules.terrain.vehicle_model import NAVLAB_TERRAIN, TERREGATOR_TERRAIN, TerrainVehicle
from tests.modules._terrain_check import discontinuity, violations

pytestmark = pytest.mark.timeout(300)  # runs ~0.1-1.5 s each with numba's cache warm; the first compiles the planner (~100 s on a busy machine)

RES = 0.2


def _grid(z: np.ndarray) -> ElevationGrid:
    z = z.astype(np.float32)
    return ElevationGrid(0.0, 0.0, RES, z, np.full_like(z, 0.01))


def _xy(width: float, height: float) -> tuple[np.ndarray, np.ndarray]:
    y, x = (np.mgrid[0:int(round(height / RES)), 0:int(round(width / RES))] + 0.5) * RES
    return x, y


def _boulder_wall(seed: int) -> ElevationGrid:
    """Return 40 m × 24 m of gently tilted ground with a wall of boulders across x ≈ 20 m, open only for y ∈ [16, 22] m."""
    rng = np.random.default_rng(seed)
    x, y = _xy(40.0, 24.0)
    z = 0.02 * x + 0.01 * y + rng.normal(0.0, 0.01, x.shape)
    for cy in np.arange(0.5, 16.0, 1.0):
        cx = 20.0 + rng.uniform(-1.0, 1.0)
        radius, height = rng.uniform(0.6, 0.9), rng.uniform(0.5, 0.9)
        z += np.where(np.hypot(x - cx, y - cy) < radius, height, 0.0)
    for _ in range(12):  # a few more boulders scattered about, away from the start and the goal
        cx, cy = rng.uniform(8.0, 32.0), rng.uniform(1.0, 23.0)
        z += np.where(np.hypot(x - cx, y - cy) < rng.uniform(0.3, 0.6), rng.uniform(0.3, 0.6), 0.0)
    return _grid(z)


def _held_to_brute_force(grid: ElevationGrid, vehicle: TerrainVehicle, plan: CrossCountryPlan) -> None:
    """Assert every pose of the path, and every pose halfway between two, satisfies every constraint cell by cell."""
    disc = discontinuity(grid.z)
    poses = plan.poses
    turn = (np.diff(poses[:, 2]) + math.pi) % (2.0 * math.pi) - math.pi
    halfway = np.column_stack([0.5 * (poses[1:, :2] + poses[:-1, :2]), poses[:-1, 2] + 0.5 * turn])
    for x, y, th in np.concatenate([poses, halfway]):
        assert not violations(grid, disc, vehicle, x, y, th), (x, y, th, violations(grid, disc, vehicle, x, y, th))


@pytest.mark.parametrize("vehicle", [NAVLAB_TERRAIN, TERREGATOR_TERRAIN], ids=lambda v: v.name)
def test_a_path_around_a_boulder_wall_is_admissible_everywhere_and_kinematically_feasible(vehicle: TerrainVehicle):
    grid = _boulder_wall(3)
    planner = CrossCountryPlanner(TerrainPyramid(grid), vehicle)
    start, goal = (5.0, 8.0, 0.0), (35.0, 8.0, 0.0)
    plan = planner.plan(start, goal)
    assert plan.poses[0] == pytest.approx(start)
    assert math.hypot(plan.poses[-1, 0] - goal[0], plan.poses[-1, 1] - goal[1]) <= planner.settings.goal_tolerance
    crossing = plan.poses[np.argmin(np.abs(plan.poses[:, 0] - 20.0))]
    assert crossing[1] > 16.0, crossing  # through the opening, 8 m off the straight line
    steps = np.hypot(*np.diff(plan.poses[:, :2], axis=0).T)
    assert steps.max() <= planner.settings.sample + 1e-9
    if vehicle.steering == "ackermann":
        assert np.all(np.abs(plan.curvature) <= 1.0 / vehicle.min_turning_radius + 1e-9)  # the Navlab's 7 m
    _held_to_brute_force(grid, vehicle, plan)


def test_the_hierarchy_decides_whole_voxels_and_queries_far_fewer_than_the_fine_grid():
    grid = _boulder_wall(5)
    plan = CrossCountryPlanner(TerrainPyramid(grid), NAVLAB_TERRAIN).plan((5.0, 8.0, 0.0), (35.0, 8.0, 0.0))
    assert plan.terrain_queries * 100 < plan.fine_configurations, (plan.terrain_queries, plan.fine_configurations)
    coarse = [lc for lc in plan.voxels if lc.level >= 1]
    assert sum(lc.admissible for lc in coarse) > 0  # whole voxels of 2 × 2 leaf squares or more decided at once
    assert sum(lc.mixed for lc in plan.voxels if lc.level >= 0) > 0  # and mixed ones refined
    assert plan.terrain_queries == sum(lc.admissible + lc.inadmissible + lc.mixed for lc in plan.voxels)
    assert set(np.unique(plan.levels)) <= {lc.level for lc in plan.voxels}
    assert (plan.levels >= 1).sum() > 0.1 * len(plan.levels)  # poses certified by a coarse voxel, not one by one


def test_a_ditch_across_the_whole_map_is_refused_naming_the_constraints():
    x, y = _xy(30.0, 14.0)
    settings = CrossCountrySettings(max_states=20_000)
    start, goal = (5.0, 7.0, 0.0), (25.0, 7.0, 0.0)
    shallow = 0.01 * y - np.clip(3.0 - np.abs(x - 15.0), 0.0, 0.1)  # a 0.1 m dip: crossed
    assert CrossCountryPlanner(TerrainPyramid(_grid(shallow)), NAVLAB_TERRAIN, settings).plan(start, goal).length < 22.0
    z = 0.01 * y - np.clip(3.0 - np.abs(x - 15.0), 0.0, 1.5)  # 1.5 m deep, 45° banks, from edge to edge
    planner = CrossCountryPlanner(TerrainPyramid(_grid(z)), NAVLAB_TERRAIN, settings)
    with pytest.raises(NoAdmissiblePath, match="no admissible path") as caught:
        planner.plan(start, goal)
    assert caught.value.constraints
    assert set(caught.value.constraints) <= {Constraint.TIP_OVER, Constraint.HIGH_CENTRING, Constraint.COLLISION}
    assert all(c.value in str(caught.value) for c in caught.value.constraints)


def test_a_start_on_a_boulder_and_a_goal_on_a_cliff_are_refused_by_name():
    x, y = _xy(30.0, 14.0)
    z = np.where(np.hypot(x - 5.0, y - 7.0) < 0.4, 0.6, 0.0) + np.where(x > 22.0, 1.2 * (x - 22.0), 0.0)  # 50° beyond
    planner = CrossCountryPlanner(TerrainPyramid(_grid(z)), NAVLAB_TERRAIN)
    with pytest.raises(InadmissibleStart, match="start") as start:
        planner.plan((5.0, 7.0, 0.0), (15.0, 7.0, 0.0))
    assert start.value.constraints and Constraint.TIP_OVER not in start.value.constraints
    with pytest.raises(InadmissibleGoal, match="goal") as goal:
        planner.plan((10.0, 7.0, 0.0), (26.0, 7.0, 0.0))
    assert Constraint.TIP_OVER in goal.value.constraints
    with pytest.raises(InadmissibleStart) as off:  # off the map: unknown terrain
        planner.plan((-3.0, 7.0, 0.0), (15.0, 7.0, 0.0))
    assert off.value.constraints == (Constraint.SENSING,)


def test_only_the_skid_steered_terregator_turns_round_in_a_dead_end():
    x, y = _xy(34.0, 16.0)
    walls = (np.abs(y - 8.0) > 3.0) | (x < 3.0)  # a corridor 6 m wide, closed at x = 3 m, 1 m walls
    grid = _grid(np.where(walls, 1.0, 0.0) + 0.005 * x)
    start, goal = (9.0, 8.0, math.pi), (30.0, 8.0, 0.0)  # facing the dead end
    navlab = CrossCountryPlanner(TerrainPyramid(grid), NAVLAB_TERRAIN, CrossCountrySettings(max_states=20_000))
    assert navlab.plan((9.0, 8.0, 0.0), goal).length < 23.0  # facing the open end, the Navlab drives out
    with pytest.raises(NoAdmissiblePath):  # forward arcs of 7 m cannot turn round in 6 m
        navlab.plan(start, goal)
    plan = CrossCountryPlanner(TerrainPyramid(grid), TERREGATOR_TERRAIN).plan(start, goal)
    assert np.isinf(plan.curvature).any()  # it turned in place
    assert math.hypot(plan.poses[-1, 0] - goal[0], plan.poses[-1, 1] - goal[1]) <= 1.0
    _held_to_brute_force(grid, TERREGATOR_TERRAIN, plan)


def test_a_heading_slice_of_the_voxels_shows_admissible_squares_that_are_so_cell_by_cell():
    grid = _boulder_wall(3)
    planner = CrossCountryPlanner(TerrainPyramid(grid), NAVLAB_TERRAIN)
    planner.plan((5.0, 8.0, 0.0), (35.0, 8.0, 0.0))
    hier = planner.hierarchy
    width = 2.0 * math.pi / hier.headings
    sliced = hier.heading_slice(0.5 * width)  # Figure 2.16: one heading interval of the voxels the plan classified
    side = hier.voxel_size(0)
    assert sliced.shape == tuple(int(d) for d in planner.pyramid.dims[hier.leaf_level])
    assert (sliced == ADMISSIBLE).sum() > 50 and (sliced == MIXED).any()
    disc = discontinuity(grid.z)
    rng = np.random.default_rng(0)
    rows, cols = np.nonzero(sliced == ADMISSIBLE)
    for k in rng.choice(len(rows), 40, replace=False):
        x, y = (cols[k] + rng.uniform(0.0, 1.0)) * side, (rows[k] + rng.uniform(0.0, 1.0)) * side
        th = rng.uniform(0.0, width)
        assert not violations(grid, disc, NAVLAB_TERRAIN, x, y, th), (x, y, th)
