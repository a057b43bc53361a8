"""Synthetic tests for each PERCEPTION stage: range features, colour classes, overlap, patches."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.perception.patch_maker import ColourModel, colour_type_name, make_patches, overlap_labels, split_label
from modules.perception.patch_maker.range_seg import (
    SurfaceType,
    jump_edges,
    surface_features,
    surface_labels,
    unwrap_range,
)


def _grid_points(f, x0=2.0, x1=10.0, y0=-3.0, y1=3.0, n=(64, 96), rng=None, noise=0.0):
    xs = np.linspace(x0, x1, n[0])
    ys = np.linspace(y0, y1, n[1])
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    Z = f(X, Y)
    if rng is not None and noise > 0:
        Z = Z + rng.normal(0, noise, Z.shape)
    return np.stack([X, Y, Z], axis=-1).astype(np.float32)


@pytest.mark.parametrize("a,b", [(0.0, 0.0), (0.12, 0.0), (0.05, -0.08)])
def test_known_plane_gives_known_normal(a: float, b: float) -> None:
    rng = np.random.default_rng(1)
    xyz = _grid_points(lambda X, Y: a * X + b * Y + 0.3, rng=rng, noise=0.005)
    valid = np.ones(xyz.shape[:2], bool)
    f = surface_features(xyz, valid)
    want = np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1)
    got = f.normal[f.ok]
    assert got.shape[0] > 0.9 * valid.size
    ang = np.degrees(np.arccos(np.clip(got @ want, -1, 1)))
    assert np.median(ang) < 1.0
    assert np.percentile(ang, 95) < 3.0
    labels = surface_labels(f)
    expected = SurfaceType.FLAT if math.degrees(math.atan(math.hypot(a, b))) < 4.0 else SurfaceType.TILTED
    assert np.mean(labels[f.ok] == expected) > 0.95


def test_stairs_are_rough_and_walls_vertical() -> None:
    stairs = _grid_points(lambda X, Y: 0.15 * np.floor(X / 0.3))
    f = surface_features(stairs, np.ones(stairs.shape[:2], bool))
    lab = surface_labels(f)
    assert np.mean(lab[f.ok] == SurfaceType.ROUGH) > 0.9
    # a wall: x = 6, z from 0 to 3 m
    Y, Z = np.meshgrid(np.linspace(-3, 3, 96), np.linspace(0.0, 3.0, 64), indexing="xy")
    wall = np.stack([np.full_like(Y, 6.0), Y, Z], axis=-1).astype(np.float32)
    fw = surface_features(wall, np.ones(wall.shape[:2], bool))
    lw = surface_labels(fw)
    assert np.mean(lw[fw.ok] == SurfaceType.VERTICAL) > 0.95


def test_unwrap_range_restores_ranges_past_the_ambiguity_interval() -> None:
    true = np.linspace(3.0, 35.0, 64)[::-1][:, None].repeat(4, axis=1)  # bottom row nearest
    wrapped = np.mod(true, 20.0)
    valid = np.ones_like(true, bool)
    un = unwrap_range(wrapped, valid, 20.0)
    np.testing.assert_allclose(un, true, atol=1e-4)


def test_jump_edges_mark_both_sides_of_a_depth_step() -> None:
    r = np.full((10, 10), 5.0, np.float32)
    r[:, 5:] = 9.0
    j = jump_edges(r, np.ones_like(r, bool), 0.5, 0.08)
    assert j[:, 4].all() and j[:, 5].all()
    assert not j[:, :4].any() and not j[:, 6:].any()


def test_colour_type_names() -> None:
    assert colour_type_name((128, 128, 130)) == "GREY"
    assert colour_type_name((70, 130, 50)) == "GREEN"
    assert colour_type_name((120, 80, 50)) == "BROWN"


def test_quadratic_discrimination_and_adaptation() -> None:
    rng = np.random.default_rng(7)
    grey, green = np.array([130.0, 130, 128]), np.array([70.0, 125, 55])
    model = ColourModel.from_predicted([(grey, (8, 8, 8)), (green, (12, 15, 10))])
    assert model.types == ("GREY", "GREEN")
    img = np.zeros((40, 40, 3))
    truth = np.zeros((40, 40), int)
    truth[:, 20:] = 1
    img[truth == 0] = rng.normal(grey, 8, ((truth == 0).sum(), 3))
    img[truth == 1] = rng.normal(green, 12, ((truth == 1).sum(), 3))
    lab, cls, post = model.classify(img)
    assert np.mean(lab == truth + 1) > 0.97
    # shaded pixels (half brightness) still get their colour type
    lab_s, _, _ = model.classify(img * 0.5)
    assert np.mean(lab_s == truth + 1) > 0.9
    # the light turns warmer frame after frame: a frozen model loses grey, the adapted one keeps up
    frozen = ColourModel.from_predicted([(grey, (8, 8, 8)), (green, (12, 15, 10))])
    for k in range(1, 11):
        frame = np.clip(img + k * np.array([5.0, 0.0, -5.0]), 0, 255)
        lab, cls, post = model.classify(frame)
        model.adapt(frame, cls, post, rate=0.5)
    lab, _, _ = model.classify(frame)
    lab_frozen, _, _ = frozen.classify(frame)
    assert np.mean(lab == truth + 1) > 0.95
    assert np.mean(lab_frozen == truth + 1) < np.mean(lab == truth + 1) - 0.1
    sun_grey = model.current()[0]
    assert sun_grey.mean[0] > 150.0 and sun_grey.mean[2] < 110.0  # the class moved with the light


def test_overlap_is_the_and_of_colour_and_surface() -> None:
    colour = np.array([[1, 1, 2, 0]])
    surface = np.array([[SurfaceType.TILTED, SurfaceType.ROUGH, SurfaceType.TILTED, SurfaceType.FLAT]], np.uint8)
    lab = overlap_labels(colour, surface)
    assert len(set(lab[0, :3].tolist())) == 3 and lab[0, 3] == 0
    assert split_label(int(lab[0, 0])) == (1, SurfaceType.TILTED)
    assert split_label(int(lab[0, 1])) == (1, SurfaceType.ROUGH)


def test_labelled_image_gives_the_known_patches() -> None:
    h, w = 40, 60
    labels = np.zeros((h, w), int)
    labels[5:25, 5:30] = 1  # a 20 x 25 px rectangle
    labels[5:25, 30:55] = 2  # its neighbour
    labels[30:38, 10:18] = 1  # a second, separate region of label 1
    labels[0:2, 0:2] = 2  # a speck below the minimum area (valid data beside nothing)
    # pixel (row, col) -> vehicle frame (x = 0.1 * (h - row), y = -0.1 * col)
    rows, cols = np.mgrid[0:h, 0:w]
    xy = np.stack([0.1 * (h - rows), -0.1 * cols], axis=-1).astype(np.float32)
    valid = labels > 0  # no data where nothing is labelled
    ps = make_patches(labels, xy, valid, colour_of={1: "GREY", 2: "GREEN"}, min_area_m2=0.2)
    assert len(ps.patches) == 3
    by_area = sorted(ps.patches, key=lambda p: -p.area_m2)
    big1 = [p for p in by_area if p.label == 1][0]
    big2 = [p for p in by_area if p.label == 2][0]
    small = [p for p in by_area if p.label == 1][1]
    assert big1.area_m2 == pytest.approx(1.9 * 2.4, rel=0.1)
    assert small.area_m2 == pytest.approx(0.7 * 0.7, rel=0.2)
    assert big2.id in big1.neighbours and big1.id in big2.neighbours
    assert small.neighbours == ()
    assert big1.colour_type == "GREY" and big2.colour_type == "GREEN"
    assert big1.centroid[1] == pytest.approx(-0.1 * 17, abs=0.15)
    # the shared edge is an object edge (another colour beside it); the outer edges beside missing data are not
    assert not any(big1.edge_flags)  # its corners all touch missing data
    on_shared = np.abs(big1.boundary[:, 1] - (-0.1 * 29.5)) < 0.15
    assert big1.boundary_flags[on_shared].mean() > 0.6
    assert not big1.boundary_flags[big1.boundary[:, 0] > 0.1 * (h - 6)].any()
    assert (ps.ids[labels == 0] == 0).all()
