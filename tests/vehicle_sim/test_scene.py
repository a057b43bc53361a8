"""Scene: ground heights and labels agree with the World, analytic solids hit where geometry says."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehicle_sim.scene import LABEL_SKY, MATERIAL_SKY, Scene
from vehicle_sim.worldfile import (
    KINDS,
    Appearance,
    FlatShape,
    MapColour,
    PostShape,
    PrismShape,
    SlopeShape,
    StairsShape,
    Sun,
    TreeShape,
    World,
    WorldObject,
)

def look(mean: tuple, std: tuple, ctype: str = "GRAY") -> dict:
    """Return the colour fields of a test object: its map colour (type, nominal = mean) and its appearance."""
    return {"colour": MapColour(type=ctype, nominal=mean), "appearance": Appearance(mean=mean, std=std)}


GREY = look((150.0, 150.0, 148.0), (6.0, 6.0, 6.0))
GREEN = look((70.0, 120.0, 50.0), (10.0, 14.0, 8.0), "GREEN")


def box(x0: float, y0: float, x1: float, y1: float) -> tuple:
    """Return an axis-aligned rectangle polygon [m]."""
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def synthetic_world(*, extra: tuple = (), sun: Sun = Sun(azimuth_deg=200.0, elevation_deg=35.0)) -> World:
    """Return a small test world: a sidewalk along +x up to x = 10 m, then side by side the same-grey
    stairs (right, y < 0: 10 steps up 1.5 m over x 10–15 m) and slope (left: 1.5 m over x 10–20 m) with a
    grass bank in the slope's plane beside it, a plaza on top (z 1.5 m), a building, a tree, a mailbox."""
    objs = [
        WorldObject(id="grass", kind="grass", role="none", cost=3.0, **GREEN, shape=FlatShape(), polygon=box(-60, -60, 60, 60)),
        WorldObject(id="walk", kind="sidewalk", role="path", cost=1.0, **GREY, shape=FlatShape(), polygon=box(-5, -1.5, 10, 1.5)),
        WorldObject(id="ramp", kind="slope", role="path", cost=1.0, **GREY, shape=SlopeShape(rise=1.5, axis_deg=0.0),
                    polygon=box(10, 0, 20, 5)),
        WorldObject(id="bank", kind="grass", role="none", cost=3.0, **GREEN, shape=SlopeShape(rise=1.5, axis_deg=0.0),
                    polygon=box(10, 5, 20, 12)),
        WorldObject(id="steps", kind="stairs", role="path", cost=1.0, **GREY,
                    shape=StairsShape(rise=1.5, axis_deg=0.0, step_rise=0.15), polygon=box(10, -5, 15, 0)),
        WorldObject(id="top1", kind="sidewalk", role="path", cost=1.0, **GREY, shape=FlatShape(z=1.5), polygon=box(15, -5, 30, 0)),
        WorldObject(id="top2", kind="sidewalk", role="path", cost=1.0, **GREY, shape=FlatShape(z=1.5), polygon=box(20, 0, 30, 5)),
        WorldObject(id="hall", kind="building", role="landmark", **look((160.0, 90.0, 70.0), (8.0, 6.0, 6.0), "BROWN"),
                    shape=PrismShape(height=6.0), polygon=box(25, 8, 32, 16)),
        WorldObject(id="oak", kind="tree", role="obstacle", **look((92.0, 72.0, 54.0), (8.0, 8.0, 8.0), "BROWN"),
                    shape=TreeShape(trunk_radius=0.2, crown_radius=2.0, height=6.0, crown_base=2.5), center=(8.0, -3.0), radius=0.2),
        WorldObject(id="box1", kind="mailbox", role="landmark", **look((40.0, 60.0, 140.0), (5.0, 5.0, 5.0), "BLUE"),
                    shape=PostShape(height=1.1), center=(6.0, 2.2), radius=0.25),
        *extra,
    ]
    return World(name="synthetic", objects=objs, sun=sun)


@pytest.fixture(scope="module")
def world() -> World:
    return synthetic_world()


@pytest.fixture(scope="module")
def scene(world: World) -> Scene:
    return Scene(world, seed=3)


def test_ground_height_and_label_match_world(world: World, scene: Scene) -> None:
    rng = np.random.default_rng(0)
    xy = rng.uniform([-20, -10], [40, 20], size=(20000, 2))
    np.testing.assert_allclose(scene.elevation(xy), world.elevation(xy), atol=1e-4)
    mat = scene.ground_material(xy[:, 0], xy[:, 1])
    labels = scene.mat_label[mat]
    np.testing.assert_array_equal(labels, world.label_at(xy))


def test_stairs_are_steps_and_slope_is_a_plane(scene: Scene) -> None:
    x = np.linspace(10.05, 14.95, 200)
    z_st = scene.ground_height(x, np.full_like(x, -3.0))
    z_sl = scene.ground_height(np.linspace(10.05, 19.95, 200), np.full(200, 3.0))
    steps = np.unique(np.round(z_st, 4))
    assert len(steps) == 10 and np.allclose(np.diff(steps), 0.15, atol=1e-4)
    assert np.allclose(np.diff(z_sl), np.diff(z_sl)[0], atol=1e-5) and z_sl[-1] > 1.4


def _column_hit(scene: Scene, origin, az: float, el: float):
    h = scene.cast(np.asarray(origin, float), np.array([az]), np.array([el]))
    return h, float(h.s[0, 0])


def test_cylinder_wall_and_crown_distances_are_analytic(scene: Scene) -> None:
    # mailbox: centre (6, 2.2), radius 0.25, height 1.1; ray from (0, 2.2, 0.5) straight along +x
    h, s = _column_hit(scene, (0.0, 2.2, 0.5), 0.0, 0.0)
    assert s == pytest.approx(6.0 - 0.25, abs=1e-4)
    assert KINDS[h.label[0, 0]] == "mailbox"
    np.testing.assert_allclose(h.normal[0, 0], [-1.0, 0.0, 0.0], atol=1e-4)
    # crown: ellipsoid centre (8, -3, 4.25), R = 2, b = 1.75; a level ray at z = 4.25 hits at 8 - 2
    h, s = _column_hit(scene, (0.0, -3.0, 4.25), 0.0, 0.0)
    assert s == pytest.approx(6.0, abs=1e-3) and KINDS[h.label[0, 0]] == "tree"


def test_building_wall_and_roof(scene: Scene) -> None:
    # wall at x = 25 facing -x; a level ray at y = 12 from x = 0, z = 2
    h, s = _column_hit(scene, (0.0, 12.0, 2.0), 0.0, 0.0)
    assert s == pytest.approx(25.0, abs=1e-4) and KINDS[h.label[0, 0]] == "building"
    # a ray from above the roof (z = 10) falling onto the roof centre (28.5, 12, 6)
    el = -math.atan2(4.0, 28.5)
    h, s = _column_hit(scene, (0.0, 12.0, 10.0), 0.0, el)
    assert s == pytest.approx(28.5, abs=1e-3)
    np.testing.assert_allclose(h.normal[0, 0], [0, 0, 1], atol=1e-6)


def test_ground_hit_is_on_the_ground_and_sky_is_empty(scene: Scene, world: World) -> None:
    el = np.radians(np.linspace(-40, 20, 61))
    az = np.radians(np.linspace(-40, 40, 81))
    h = scene.cast(np.array([0.0, 0.0, 2.0]), az, el)
    ground = h.hit & np.isin(h.label, [KINDS.index(k) for k in ("grass", "sidewalk", "slope", "stairs")]) & ~h.riser
    xyz = h.xyz[ground].astype(float)
    # ground hits lie on the surface (the march interpolates between 4 cm-ish samples)
    assert np.abs(xyz[:, 2] - world.elevation(xyz[:, :2])).max() < 0.05
    assert (h.label[h.material == MATERIAL_SKY] == LABEL_SKY).all()
    assert (h.material[el > np.radians(5)] == MATERIAL_SKY).sum() > 0


def test_tree_shadow_falls_away_from_the_sun(scene: Scene) -> None:
    # sun azimuth 200° (compass: SSW), elevation 35°: the crown (centre height 4.25 m) casts its shadow
    # 4.25 / tan 35° = 6.07 m from the trunk (8, -3) towards compass azimuth 20°, 3.2 m long each way
    d = 4.25 / math.tan(math.radians(35.0))
    along = np.array([math.sin(math.radians(20.0)), math.cos(math.radians(20.0))])
    centre = np.array([8.0, -3.0]) + d * along
    on_walk = np.array([8.0, -3.0]) + 4.0 * along  # 4 m from the trunk: y = 0.76, on the sidewalk
    assert abs(on_walk[1]) < 1.5
    for p in (centre, on_walk):
        assert scene.sunlit_at(np.array([p[0]]), np.array([p[1]]))[0] < 0.1
    behind = np.array([8.0, -3.0]) - d * along  # the sun side of the tree is lit
    assert scene.sunlit_at(np.array([behind[0]]), np.array([behind[1]]))[0] > 0.99


def test_column_order_does_not_change_what_is_seen(scene: Scene) -> None:
    # descending azimuths (image order, culled per solid) and ascending ones (no culling) see the same
    az = np.radians(np.linspace(80, -10, 181))
    el = np.radians(np.linspace(10, -30, 41))
    o = np.array([0.0, 0.0, 2.0])
    a = scene.cast(o, az, el)
    b = scene.cast(o, az[::-1], el)
    np.testing.assert_array_equal(a.label, b.label[:, ::-1])
    np.testing.assert_allclose(a.s, b.s[:, ::-1], rtol=1e-6)
    assert (a.label == KINDS.index("building")).sum() > 50


def test_weather_comes_and_goes_on_the_ground_covers_only(world: World) -> None:
    """Wet patches and leaves change the ground over a run (seeded: the same at the same time), never the solids."""
    from vehicle_sim.worldfile import Weather

    wet = World(name="wet", objects=world.objects, sun=world.sun,
                weather=Weather(wet_cover=0.3, leaf_cover=0.1, swing=0.8, period_s=100.0))
    dry, rainy, again = Scene(world, seed=3), Scene(wet, seed=3), Scene(wet, seed=3)
    az = np.linspace(0.6, -0.6, 120)
    el = np.linspace(-0.15, -0.6, 60)
    hits = rainy.cast(np.array([-4.0, 0.0, 1.6]), az, el)
    ground = np.isin(hits.material, [1, 2])  # the lawn and the walk
    assert ground.mean() > 0.5
    base = dry.albedo(hits, 0.0)
    wet_a, wet_b = rainy.covers_at(0.0), rainy.covers_at(30.0)
    assert wet_a != wet_b and all(0.0 < c < 1.0 for c in wet_a + wet_b)
    a, b = rainy.albedo(hits, 0.0), rainy.albedo(hits, 30.0)
    np.testing.assert_array_equal(a, again.albedo(hits, 0.0))  # reproducible from the seed
    changed = np.any(np.abs(a - base) > 1.0, axis=-1)
    assert 0.05 < changed[ground].mean() < 0.8  # patches of the ground, not all of it
    assert not changed[~ground & hits.hit].any()  # trees, buildings and mailboxes stay as they are
    assert np.any(np.abs(a - b) > 1.0, axis=-1)[ground].mean() > 0.02  # and the patches move over the run
    assert dry.albedo(hits, 0.0).tolist() == dry.albedo(hits, 30.0).tolist()  # no weather: nothing changes
