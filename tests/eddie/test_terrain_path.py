"""EDDIE's terrain module core: ERIM images of a real simulated scene → the terrain map → a path around a box, in `local`."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddie.terrain import CrossCountryPathConfig, terrain_path
from modules.terrain.errors import TerrainPlanningError
from modules.terrain.terrain_map import TerrainMap
from modules.terrain.vehicle_model import NAVLAB_TERRAIN
from tests.modules._terrain_scenes import box, grid, shoot, terrain_world
from wire.se2 import inverse, transform_points
from vehicle_sim.scene import Scene

pytestmark = pytest.mark.timeout(900)  # quiet run ~5 s each with numba's cache warm; a cold cache compiles the locus code and the planner (minutes on a busy machine)

LOCAL_FROM_WORLD = (3.0, -2.0, 0.5)  # the controller's frame is not the world's: the path must be moved into it
BOX = (8.0, -1.5, 9.0, 1.5)


@pytest.fixture(scope="module")
def terrain() -> TerrainMap:
    xs, _ = grid()
    world = terrain_world(np.zeros_like(xs), (box(*BOX, 1.2),))
    scene = Scene(world, seed=0)
    m = TerrainMap((-10.0, -12.0, 24.0, 12.0), 0.2, NAVLAB_TERRAIN)
    for k, x in enumerate((-10.0, -6.0, -2.0, 2.0)):  # the ground under the start (2, 0) is seen from behind it
        _, image, pose = shoot(world, x, 0.0, 0.0, seed=k, scene=scene)
        changed, _ = m.add_image(image, pose)
        assert changed
    return m


def _world(poses: tuple) -> np.ndarray:
    p = np.asarray(poses)
    return transform_points(inverse(LOCAL_FROM_WORLD), p[:, :2])


def test_the_path_goes_round_the_box_and_reaches_the_goal_in_the_controller_s_frame(terrain: TerrainMap) -> None:
    path = terrain_path(terrain, (2.0, 0.0, 0.0), (17.0, 0.0), LOCAL_FROM_WORLD, sensed_at=2.0,
                        cfg=CrossCountryPathConfig(lookahead_m=60.0))
    assert path.reaches_goal and path.terrain_queries > 0
    xy = _world(path.poses)
    assert xy[0] == pytest.approx([2.0, 0.0], abs=1e-6)
    assert math.hypot(xy[-1, 0] - 17.0, xy[-1, 1]) <= 1.0
    beside = xy[(xy[:, 0] > BOX[0] - 1.0) & (xy[:, 0] < BOX[2] + 1.0)]
    assert len(beside) and np.all(np.abs(beside[:, 1]) > BOX[3] + NAVLAB_TERRAIN.body_half_width - 0.05), beside
    assert path.poses[0][2] == pytest.approx(LOCAL_FROM_WORLD[2])  # the heading moved into `local` too
    cmd = path.command("terrain", 2)
    assert cmd.points[0] == pytest.approx(path.poses[0][:2]) and cmd.sensed_at == 2.0 and len(cmd.points) == len(path.poses)


def test_the_controller_gets_only_the_look_ahead(terrain: TerrainMap) -> None:
    path = terrain_path(terrain, (2.0, 0.0, 0.0), (17.0, 0.0), LOCAL_FROM_WORLD, sensed_at=2.0,
                        cfg=CrossCountryPathConfig(lookahead_m=5.0))
    xy = _world(path.poses)
    assert not path.reaches_goal
    assert 4.5 <= float(np.hypot(*np.diff(xy, axis=0).T).sum()) <= 5.0 + 1e-6


def test_a_goal_on_the_box_is_refused_with_the_planner_s_reason(terrain: TerrainMap) -> None:
    with pytest.raises(TerrainPlanningError, match="goal"):
        terrain_path(terrain, (2.0, 0.0, 0.0), (8.5, 0.0), LOCAL_FROM_WORLD, sensed_at=2.0)
