"""The ERIM-like range model: 8 cm quantisation, 20.48 m ambiguity interval, noise, mixed points."""

from __future__ import annotations

import numpy as np
import pytest

from tests.vehicle_sim.test_scene import GREEN, box, look
from vehicle_sim.scene import Scene
from vehicle_sim.sensors.laser import (
    LaserConfig,
    code_to_range,
    depth_edges,
    laser_angles,
    mix_returns,
    quantise_range,
    range_sigma,
    scan,
)
from vehicle_sim.worldfile import KINDS, FlatShape, PrismShape, World, WorldObject

WALL = look((150.0, 140.0, 130.0), (5.0, 5.0, 5.0))
QUIET = LaserConfig(sigma0=0.0, sigma_k=0.0, mixed_probability=0.0, reflectance_noise=0.0)


def walls_world(*walls: tuple) -> World:
    """Return flat grass with tall walls (boxes [m])."""
    objs = [WorldObject(id="grass", kind="grass", role="none", cost=3.0, **GREEN, shape=FlatShape(), polygon=box(-80, -80, 80, 80))]
    for i, b in enumerate(walls):
        objs.append(WorldObject(id=f"wall{i}", kind="building", role="landmark", **WALL, shape=PrismShape(height=20.0), polygon=box(*b)))
    return World(name="walls", objects=objs)


def test_quantisation_is_8_cm_in_8_bits() -> None:
    cfg = LaserConfig()
    r = np.arange(0.0, 20.4, 0.0131)
    code = quantise_range(r, cfg)
    assert code.dtype == np.uint8
    assert np.abs(code_to_range(code, cfg) - r).max() <= 0.04 + 1e-6
    assert cfg.ambiguity == pytest.approx(20.48)


def test_range_wraps_past_the_ambiguity_interval() -> None:
    cfg = LaserConfig()
    r = np.array([0.5, 3.33, 7.01, 12.9, 19.7])
    np.testing.assert_array_equal(quantise_range(r + 20.48, cfg), quantise_range(r, cfg))
    np.testing.assert_array_equal(quantise_range(r + 2 * 20.48, cfg), quantise_range(r, cfg))
    assert code_to_range(quantise_range(np.array([25.0]), cfg), cfg)[0] == pytest.approx(25.0 - 20.48, abs=0.04)


def test_a_wall_beyond_20_m_reads_short() -> None:
    scene = Scene(walls_world((25, -40, 26, 40)), seed=0)
    f = scan(scene, np.array([0.0, 0.0, 2.0]), 0.0, QUIET, np.random.default_rng(0))
    wall = f.labels == KINDS.index("building")
    assert wall.sum() > 500
    rt = f.range_true[wall]
    assert rt.min() > 24.9 and rt.max() < 40.0
    # measured = true range modulo 20.48 m, in 8 cm steps
    np.testing.assert_allclose(f.range[wall], np.round((rt % 20.48) / 0.08) % 256 * 0.08, atol=1e-4)
    assert f.range[wall].max() < 20.48 - 4.0  # nothing reads like a 25 m range


def test_range_noise_grows_with_range() -> None:
    cfg = LaserConfig(mixed_probability=0.0)
    r = np.array([2.0, 5.0, 10.0, 20.0, 35.0])
    s = range_sigma(r, np.full(5, 0.5), cfg)
    assert np.all(np.diff(s) > 0)
    assert range_sigma(np.array([10.0]), np.array([0.1]), cfg)[0] > s[2]  # dark surfaces are noisier
    errs = {}
    for d in (5.0, 18.0):
        scene = Scene(walls_world((d, -40, d + 1, 40)), seed=0)
        e = []
        for k in range(4):
            f = scan(scene, np.array([0.0, 0.0, 2.0]), 0.0, cfg, np.random.default_rng(k))
            m = (f.labels == KINDS.index("building")) & f.valid
            e.append((f.range[m] - f.range_true[m])[:400])
        errs[d] = np.concatenate(e).std()
    assert errs[18.0] > 2.0 * errs[5.0]


def test_mix_returns_gives_points_between_surfaces() -> None:
    amb = 20.48
    assert mix_returns(np.array([8.0]), np.array([9.0]), np.array([1.0]), np.array([1.0]), amb)[0] == pytest.approx(8.5, abs=0.01)
    assert mix_returns(np.array([8.0]), np.array([15.0]), np.array([1.0]), np.array([0.0]), amb)[0] == pytest.approx(8.0)
    m = mix_returns(np.full(9, 8.0), np.full(9, 12.0), np.linspace(0.1, 0.9, 9), np.linspace(0.9, 0.1, 9), amb)
    assert np.all((m > 8.0) & (m < 12.0)) and np.all(np.diff(m) < 0)


def test_mixed_points_appear_only_at_depth_edges() -> None:
    # near wall at 8 m on the right (y < 0), far wall at 15 m on the left (y > 0): a vertical depth edge at az 0
    scene = Scene(walls_world((8, -40, 9, 0), (15, 0, 16, 40)), seed=0)
    origin = np.array([0.0, 0.0, 2.0])
    clean = scan(scene, origin, 0.0, QUIET, np.random.default_rng(1))
    mixed = scan(scene, origin, 0.0, QUIET.model_copy(update={"mixed_probability": 1.0}), np.random.default_rng(1))
    walls = clean.labels == KINDS.index("building")
    rt = clean.range_true.astype(float)
    off_clean = walls & (np.abs(clean.range - rt) > 0.3)
    off = walls & (np.abs(mixed.range - rt) > 0.3)
    assert not off_clean.any()  # without mixing every point is on its own surface
    assert off.sum() >= 10  # a column of mixed points on the edge …
    edge, _ = depth_edges(rt, QUIET)
    assert edge[off].all()  # … only at depth discontinuities …
    # in the rows where both walls fill the middle of the image, the only edge is straight ahead
    az, _ = laser_angles(QUIET)
    mid = slice(64, 192)
    full = walls[:, mid].all(axis=1)
    full = full & np.roll(full, 1) & np.roll(full, -1)
    rows, cols = np.nonzero(off[:, mid] & full[:, None])
    assert len(rows) >= 10
    assert np.all(np.abs(np.degrees(az[cols + mid.start])) < 1.0)
    rows, cols = np.nonzero(off)
    for r, c in zip(rows, cols):  # … and between the two surfaces, on neither
        nb = rt[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2]
        nb = nb[np.isfinite(nb)]
        assert nb.min() - 0.05 <= mixed.range[r, c] <= nb.max() + 0.05
    assert mixed.mixed[off].all()


def test_oblique_ground_is_not_a_depth_edge() -> None:
    # open flat ground: range grows fast from row to row near the horizon, but continuously
    scene = Scene(walls_world(), seed=0)
    f = scan(scene, np.array([0.0, 0.0, 2.0]), 0.0, QUIET.model_copy(update={"mixed_probability": 1.0}), np.random.default_rng(0))
    ground = f.valid & (f.range_true < 20.0)
    assert ground.sum() > 5000
    assert not f.mixed[ground].any()
    np.testing.assert_allclose(f.range[ground], np.round(f.range_true[ground] / 0.08) * 0.08, atol=1e-4)
