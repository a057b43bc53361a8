"""Rough ground in the simulator: the terrain entry of a world file, the body on its wheels, the hazards, generated worlds."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from wire.drive import DriveCommand
from wire.terrainfile import TerrainRaster, TerrainRef, save_terrain
from vehicle_sim.generated import GENERATORS
from vehicle_sim.ground_contact import body_for, hazards, rest_on_ground
from vehicle_sim.simulator import SimConfig, Simulator
from vehicle_sim.worldfile import StartPose, World, WorldFileError, load_world

RES = 0.1


def _raster(z_of_xy, x0: float = -20.0, y0: float = -20.0, nx: int = 601, ny: int = 401) -> TerrainRaster:
    """Return a raster whose height at (x, y) [m] is z_of_xy(x, y), over [x0, x0 + (nx - 1)·0.1] × [y0, …]."""
    ys, xs = np.meshgrid(y0 + np.arange(ny) * RES, x0 + np.arange(nx) * RES, indexing="ij")
    return TerrainRaster(x0, y0, RES, np.asarray(z_of_xy(xs, ys), np.float32))


def _world(z_of_xy, start=(0.0, 0.0, 0.0)) -> World:
    return World(name="rough", objects=(), start=StartPose(x=start[0], y=start[1], yaw_deg=math.degrees(start[2])),
                 terrain=TerrainRef(file="rough.npz"), terrain_raster=_raster(z_of_xy))


def _world_file(tmp_path: Path, terrain: object) -> Path:
    doc = {"type": "FeatureCollection", "name": "rough", "terrain": terrain, "features": [
        {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [[[-5, -5], [5, -5], [5, 5], [-5, 5], [-5, -5]]]},
         "properties": {"id": "g", "kind": "grass", "role": "none", "cost": 1.0,
                        "colour": {"type": "GREEN", "nominal": [60, 120, 50]}, "shape": {"type": "flat", "z": 0.0}}}]}
    path = tmp_path / "rough.world.geojson"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.timeout(60)  # quiet run ~1 s
def test_a_world_file_names_its_raster_and_heights_lie_on_it(tmp_path: Path) -> None:
    save_terrain(tmp_path / "rough.npz", _raster(lambda x, y: 0.1 * x))
    w = load_world(_world_file(tmp_path, {"file": "rough.npz"}))
    assert w.terrain_raster is not None
    assert w.elevation_at(2.0, 1.0) == pytest.approx(0.2, abs=0.01)  # the grass cover (z 0) lies on the terrain
    assert w.elevation(np.array([[-3.0, 0.0], [50.0, 0.0]])) == pytest.approx([-0.3, 4.0], abs=0.01)  # the edge holds outside


@pytest.mark.timeout(60)  # quiet run ~1 s
@pytest.mark.parametrize("entry, says", [
    ({"file": "absent.npz"}, "terrain.file"),
    ({"file": "rough.tif"}, ".npz"),
    ({"path": "rough.npz"}, "terrain"),
    ({"file": "broken.npz"}, "terrain.file"),
])
def test_a_bad_terrain_entry_is_refused_naming_it(tmp_path: Path, entry: dict, says: str) -> None:
    np.savez_compressed(tmp_path / "broken.npz", origin=np.zeros(2))  # no resolution, no heights
    with pytest.raises(WorldFileError) as err:
        load_world(_world_file(tmp_path, entry))
    assert says in str(err.value) and "Traceback" not in str(err.value)


@pytest.mark.timeout(60)  # quiet run ~1 s
@pytest.mark.parametrize("vehicle", ["navlab", "terregator"])
def test_the_body_rests_on_a_slope_with_its_roll_and_pitch(vehicle: str) -> None:
    body = body_for(vehicle)
    height = _world(lambda x, y: 0.10 * x + 0.05 * y).elevation
    for yaw in (0.0, math.radians(90.0)):
        g = rest_on_ground(height, 3.0, 2.0, yaw, body)
        # nose up the 10 % grade heading east (pitch < 0 by REP-103), left side up heading north
        c, s = math.cos(yaw), math.sin(yaw)
        along, across = 0.10 * c + 0.05 * s, -0.10 * s + 0.05 * c
        assert g.pitch == pytest.approx(-math.atan(along), abs=math.radians(0.3))
        assert g.roll == pytest.approx(math.atan(across), abs=math.radians(0.3))
    _, found = hazards(height, 3.0, 2.0, 0.0, body)
    assert found == []


@pytest.mark.timeout(60)  # quiet run ~1 s
def test_a_steep_side_slope_tips_a_ridge_high_centres_a_wall_blocks() -> None:
    body = body_for("navlab")
    assert 30.0 < math.degrees(body.max_roll) < 45.0 and "assumed" in body.source
    side = _world(lambda x, y: math.tan(body.max_roll + math.radians(3.0)) * y).elevation
    assert [h.kind for h in hazards(side, 0.0, 0.0, 0.0, body)[1]] == ["tip-over"]
    ridge = _world(lambda x, y: np.where((x > 1.2) & (x < 2.4), 0.6 * np.clip(1.0 - np.abs(y) / 0.6, 0.0, None), 0.0)).elevation
    assert [h.kind for h in hazards(ridge, 0.0, 0.0, 0.0, body)[1]] == ["high-centred"]
    wall = _world(lambda x, y: np.where(x > 3.8, 0.8, 0.0)).elevation
    assert "collision" in [h.kind for h in hazards(wall, 0.0, 0.0, 0.0, body)[1]]


@pytest.mark.timeout(60)  # quiet run ~2 s
def test_driving_over_a_bank_logs_a_tip_over_and_the_vehicle_stays() -> None:
    # level ground, then a side slope turning steeper than the Navlab's roll limit from x = 8 m to 28 m
    limit = body_for("navlab").max_roll + math.radians(5.0)
    world = _world(lambda x, y: np.tan(limit * np.clip((x - 8.0) / 20.0, 0.0, 1.0)) * y)
    sim = Simulator(world, SimConfig(vehicle="navlab", seed=1))
    assert sim.truth().roll == 0.0 and sim.disabled is None
    events = []
    for _ in range(120):
        sim.submit(DriveCommand(speed=1.5, curvature=0.0))
        events += sim.advance(0.2)
    kinds = [e.kind for e in events]
    assert "tip-over" in kinds and "collision" not in kinds and sim.disabled == "tip-over"
    stuck = sim.state.x
    assert 8.0 < stuck < 28.0
    truth = sim.truth()
    assert abs(truth.roll) > body_for("navlab").max_roll
    sim.submit(DriveCommand(speed=1.5, curvature=0.0))
    sim.advance(1.0)
    assert sim.state.x == stuck


@pytest.mark.timeout(240)  # quiet run ~25 s (three generations of a 200-400 m world)
def test_worldgen_cross_country_is_reproducible_and_checked(tmp_path: Path) -> None:
    a = GENERATORS["cross-country"](1, tmp_path / "a", None)
    b = GENERATORS["cross-country"](1, tmp_path / "b", None)
    assert [p.name for p in a] == [p.name for p in b]
    digest = lambda p: hashlib.sha256(p.read_bytes()).hexdigest()  # noqa: E731
    assert [digest(p) for p in a] == [digest(p) for p in b]
    world = load_world(a[0])
    survey = load_world(a[2], kind="map")
    mission = yaml.safe_load(a[4].read_text())
    goal = mission["steps"][0]["destination"]
    start = mission["start"]
    assert goal["off_road"] is True and not world.edges
    assert 200.0 <= math.hypot(goal["x"] - start["x"], goal["y"] - start["y"]) <= 400.0
    assert survey.terrain_raster is not None and survey.terrain_raster.resolution == 10.0
    # the survey map is coarse and has its own error: not the truth, but close to it
    cx = survey.terrain_raster.origin_x + 10.0 * np.arange(survey.terrain_raster.z.shape[1])
    cy = survey.terrain_raster.origin_y + 10.0 * np.arange(survey.terrain_raster.z.shape[0])
    X, Y = np.meshgrid(cx, cy)
    inside = (X > 10) & (X < world.terrain_raster.origin_x + 10 * RES * (world.terrain_raster.z.shape[1] - 1) - 10)
    err = survey.terrain_raster.z[inside] - world.elevation(np.column_stack([X[inside], Y[inside]]))
    assert 0.05 < np.sqrt(np.mean(err ** 2)) < 1.5
    # the start and the goal stand clear on the truth
    sim = Simulator(world, SimConfig(vehicle="navlab", seed=0))
    assert sim.blocked_at(start["x"], start["y"], math.radians(start["yaw_deg"])) is None
    c = GENERATORS["cross-country"](2, tmp_path / "c", None)
    assert digest(c[1]) != digest(a[1])
