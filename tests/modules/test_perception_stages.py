"""Synthetic tests for each PERCEPTION stage: range features, colour classes, overlap, patches."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.perception.patch_maker import ColourModel, ColourModelError, make_patches, overlap_labels, split_label
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


# What the surfaces look like (unknown to PERCEPTION) and what the map says of them (type, nominal colour).
GRAY_TRUE, GREEN_TRUE = np.array([130.0, 130, 128]), np.array([70.0, 125, 55])
MAP_COLOURS = [("GRAY", (165.0, 165.0, 160.0)), ("GREEN", (90.0, 140.0, 70.0))]
SHADE_TINT = np.array([0.95, 1.0, 1.1])  # this test's own skylight


def _scene(rng: np.random.Generator, shade: float = 0.45) -> tuple[np.ndarray, np.ndarray]:
    """Return a 40×40 image (gray walk left, green lawn right, the lower half in shade) and its truth (0 gray, 1 green)."""
    img = np.zeros((40, 40, 3))
    truth = np.zeros((40, 40), int)
    truth[:, 20:] = 1
    img[truth == 0] = rng.normal(GRAY_TRUE, 6, ((truth == 0).sum(), 3))
    img[truth == 1] = rng.normal(GREEN_TRUE, 10, ((truth == 1).sum(), 3))
    img[20:] *= shade * SHADE_TINT
    return img, truth


def _strips(truth: np.ndarray) -> np.ndarray:
    """Return what the PERCEPTION MONITOR vouches for: a strip well inside each object, across sun and shade."""
    known = np.zeros_like(truth)
    known[:, 4:8] = 1
    known[:, 30:34] = 2
    return known


def test_colour_classes_start_from_the_map_and_fit_the_labelled_pixels() -> None:
    rng = np.random.default_rng(7)
    img, truth = _scene(rng)
    model = ColourModel.from_map(MAP_COLOURS)
    assert model.types == ("GRAY", "GREEN")
    assert [c.name.split("-")[-1] for c in model.classes] == ["lit", "shade", "lit", "shade"]
    lab0, _, _ = model.classify(img)
    before = np.mean(lab0 == truth + 1)
    assert model.train(img, _strips(truth)) > 200
    lab, _, _ = model.classify(img)
    after = np.mean(lab == truth + 1)
    assert after > 0.98 and after >= before
    lit, shade = model.current()[0], model.current()[1]
    # the lit class moved most of the way from the nominal to the walk's true colour, the shaded one to its shade
    assert np.linalg.norm(np.array(lit.mean) - GRAY_TRUE) < 0.3 * np.linalg.norm(np.array(MAP_COLOURS[0][1]) - GRAY_TRUE)
    shaded = 0.45 * GRAY_TRUE * SHADE_TINT
    start = np.array(ColourModel.from_map(MAP_COLOURS).classes[1].mean)
    assert np.linalg.norm(np.array(shade.mean) - shaded) < 0.3 * np.linalg.norm(start - shaded)
    # a frame of another place, in another shade: the fitted classes still hold
    img2, truth2 = _scene(np.random.default_rng(8), shade=0.5)
    lab2, _, _ = model.classify(img2)
    assert np.mean(lab2 == truth2 + 1) > 0.97


def test_training_ignores_what_does_not_look_like_its_type() -> None:
    img, truth = _scene(np.random.default_rng(3))
    img[2:6, 4:8] = (150.0, 100.0, 50.0)  # leaves on the walk, inside the strip vouched for as GRAY
    model = ColourModel.from_map(MAP_COLOURS)
    model.train(img, _strips(truth))
    lit = model.current()[0]
    assert np.linalg.norm(np.array(lit.mean) - GRAY_TRUE) < 0.3 * np.linalg.norm(np.array(MAP_COLOURS[0][1]) - GRAY_TRUE)
    assert lit.mean[2] > 0.9 * lit.mean[0]  # the leaves (little blue) did not drag the class towards brown
    assert ColourModel.from_map(MAP_COLOURS).train(img, np.zeros_like(truth)) == 0  # nothing vouched for, nothing learnt


def test_the_classes_follow_the_light_frame_after_frame() -> None:
    img, truth = _scene(np.random.default_rng(7), shade=1.0)
    model = ColourModel.from_map(MAP_COLOURS)
    model.train(img, _strips(truth))
    frozen = ColourModel.from_map(MAP_COLOURS)
    frozen.train(img, _strips(truth))
    # the light turns warmer frame after frame: a frozen model loses gray, the adapted one keeps up
    for k in range(1, 11):
        frame = np.clip(img + k * np.array([5.0, 0.0, -5.0]), 0, 255)
        lab, _, post = model.classify(frame)
        model.adapt(frame, lab, post, rate=0.5)
    lab, _, _ = model.classify(frame)
    lab_frozen, _, _ = frozen.classify(frame)
    assert np.mean(lab == truth + 1) > 0.95
    assert np.mean(lab_frozen == truth + 1) < np.mean(lab == truth + 1) - 0.1
    lit_gray = model.current()[0]
    assert lit_gray.mean[0] > 150.0 and lit_gray.mean[2] < 110.0  # the class moved with the light


def test_bad_colours_are_named() -> None:
    with pytest.raises(ColourModelError, match="three finite channels"):
        ColourModel.from_map([("GRAY", (1.0, 2.0))])
    with pytest.raises(ColourModelError, match="no colour type"):
        ColourModel.from_map([("", (1.0, 2.0, 3.0))])


def test_small_specks_join_the_patch_around_them() -> None:
    h, w = 30, 40
    labels = np.ones((h, w), int)
    labels[:, 20:] = 2
    labels[10:12, 5:7] = 0  # a rejected speck (leaves) inside the walk
    labels[14:16, 19:21] = 3  # a speck of another colour astride the border between walk and lawn
    rows, cols = np.mgrid[0:h, 0:w]
    xy = np.stack([0.1 * (h - rows), -0.1 * cols], axis=-1).astype(np.float32)
    valid = np.ones((h, w), bool)
    colours = {1: "GRAY", 2: "GREEN", 3: "BROWN"}
    ps = make_patches(labels, xy, valid, colour_of=colours, min_area_m2=0.1)
    walk = next(p for p in ps.patches if p.label == 1)
    assert (ps.ids[10:12, 5:7] == walk.id).all()  # swallowed by the walk around it
    assert (ps.ids[14:16, 19:21] == 0).all()  # half beside each: nobody's
    kept = make_patches(labels, xy, valid, colour_of=colours, min_area_m2=0.1, speck_pixels=0)
    assert (kept.ids[10:12, 5:7] == 0).all()


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
    ps = make_patches(labels, xy, valid, colour_of={1: "GRAY", 2: "GREEN"}, min_area_m2=0.2)
    assert len(ps.patches) == 3
    by_area = sorted(ps.patches, key=lambda p: -p.area_m2)
    big1 = [p for p in by_area if p.label == 1][0]
    big2 = [p for p in by_area if p.label == 2][0]
    small = [p for p in by_area if p.label == 1][1]
    assert big1.area_m2 == pytest.approx(1.9 * 2.4, rel=0.1)
    assert small.area_m2 == pytest.approx(0.7 * 0.7, rel=0.2)
    assert big2.id in big1.neighbours and big1.id in big2.neighbours
    assert small.neighbours == ()
    assert big1.colour_type == "GRAY" and big2.colour_type == "GREEN"
    assert big1.centroid[1] == pytest.approx(-0.1 * 17, abs=0.15)
    # the shared edge is an object edge (another colour beside it); the outer edges beside missing data are not
    assert not any(big1.edge_flags)  # its corners all touch missing data
    on_shared = np.abs(big1.boundary[:, 1] - (-0.1 * 29.5)) < 0.15
    assert big1.boundary_flags[on_shared].mean() > 0.6
    assert not big1.boundary_flags[big1.boundary[:, 0] > 0.1 * (h - 6)].any()
    assert (ps.ids[labels == 0] == 0).all()


def test_perception_copies_no_constant_of_the_renderer() -> None:
    """The camera's ambient factor and sky tint are the simulator's; PERCEPTION must learn shade from the images."""
    import io
    import tokenize
    from pathlib import Path

    from vehicle_sim.sensors import camera

    perception = Path(__file__).resolve().parents[2] / "modules" / "perception"
    literals: dict[float, str] = {}
    for path in perception.rglob("*.py"):
        for tok in tokenize.generate_tokens(io.StringIO(path.read_text()).readline):
            if tok.type == tokenize.NUMBER:
                literals[round(float(tok.string), 6)] = f"{path.name}:{tok.start[0]}"
    ambient = round(camera.CameraConfig().ambient, 6)
    assert ambient not in literals, f"the camera's ambient factor {ambient} at {literals.get(ambient)}"
    tint = [round(float(v), 6) for v in camera._SKY_TINT]  # one channel alone (0.9) may be a coincidence, not all three
    assert not all(v in literals for v in tint), f"the camera's sky tint {tint} at {[literals[v] for v in tint]}"
