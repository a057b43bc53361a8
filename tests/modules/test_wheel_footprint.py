"""The ground under the vehicle is known from its wheels and inclinometer: the plane it stands on fills the unknown
cells under its body (and its blind ground ahead at the start), never the cells the laser measured."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.terrain_map import TerrainMap
from modules.terrain.vehicle_model import NAVLAB_TERRAIN
from modules.terrain.vehicle_pose import VehiclePose
from modules.terrain.wheel_footprint import FOOTPRINT_SIGMA_M, footprint_heights

pytestmark = pytest.mark.timeout(60)  # < 1 s at load 5–7 (not measured quiet)


def _grid() -> ElevationGrid:
    return ElevationGrid.unknown(0.0, 0.0, 0.2, 100, 100)


def _centre(g: ElevationGrid, x: float, y: float) -> tuple[int, int]:
    return g.cell_of(x, y)


def test_the_plane_the_vehicle_stands_on_fills_the_cells_under_it() -> None:
    g = _grid()
    pitch = math.radians(-6.0)  # nose up: the ground rises ahead
    yaw = math.radians(30.0)
    pose = VehiclePose(10.0, 10.0, 1.3, 0.0, pitch, yaw)
    footprint_heights(g, pose, NAVLAB_TERRAIN, margin=0.0)
    rise = math.tan(-pitch)
    for d in (-0.8, 1.85, 4.4):  # along the heading, under the body (the pose is the rear axle; the body reaches 1.0 m behind, 4.6 m ahead)
        i, j = _centre(g, 10.0 + d * math.cos(yaw), 10.0 + d * math.sin(yaw))
        x, y = g.centre_of(i, j)
        along = (x - 10.0) * math.cos(yaw) + (y - 10.0) * math.sin(yaw)
        assert g.z[i, j] == pytest.approx(1.3 + rise * along, abs=0.01)
        assert g.sigma[i, j] == pytest.approx(FOOTPRINT_SIGMA_M)
    i, j = _centre(g, 10.0 + 5.0 * math.cos(yaw), 10.0 + 5.0 * math.sin(yaw))
    assert np.isnan(g.z[i, j])  # beyond the bumper: not the vehicle's to know
    i, j = _centre(g, 10.0 - 1.6 * math.sin(yaw), 10.0 + 1.6 * math.cos(yaw))
    assert np.isnan(g.z[i, j])  # beside it
    i, j = _centre(g, 10.0 - 1.5 * math.cos(yaw), 10.0 - 1.5 * math.sin(yaw))
    assert np.isnan(g.z[i, j])  # behind the rear bumper


def test_measured_cells_keep_their_heights_and_the_start_pad_reaches_ahead() -> None:
    g = _grid()
    g.z[50, 50], g.sigma[50, 50] = 7.0, 0.01  # a laser cell under the body
    pose = VehiclePose(*g.centre_of(50, 50), 0.0)
    footprint_heights(g, pose, NAVLAB_TERRAIN, ahead=4.0)
    assert g.z[50, 50] == 7.0 and g.sigma[50, 50] == pytest.approx(0.01)
    i, j = g.cell_of(pose.x + 6.0, pose.y)
    assert g.z[i, j] == pytest.approx(0.0)  # 6 m ahead: inside the pad (bumper 4.6 m ahead of the rear axle, + 4 m)
    i, j = g.cell_of(pose.x + 9.5, pose.y)
    assert np.isnan(g.z[i, j])


def test_a_terrain_map_reports_the_tiles_the_footprint_changed() -> None:
    tm = TerrainMap((0.0, 0.0, 40.0, 40.0), 0.2, NAVLAB_TERRAIN, tile_cells=32)
    changed = tm.add_footprint(VehiclePose(20.0, 20.0, 0.5, 0.0, 0.0, 0.0))
    assert changed and all(0 <= t.ti < 7 and 0 <= t.tj < 7 for t in changed)
    tiles = tm.tiles(changed, 3.0)
    known = sum(int(np.isfinite(t.heights()[0]).sum()) for t in tiles)
    assert known >= (5.6 * 2.1) / 0.04  # at least the body's cells
    assert tm.height_near(20.0, 20.0) == pytest.approx(0.5)
