"""SCARF's texture operator, its ISODATA colour-model generator, and SCARF over vision workers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.parallel import VisionPool
from modules.road_following import CameraGeometry, Scarf, ScarfConfig
from modules.road_following.colour_classes import ColourClasses, attach_texture, classify
from modules.road_following.isodata import isodata, isodata_classes
from modules.road_following.texture import blue_pyramid, roberts, texture_image

pytestmark = pytest.mark.timeout(240)  # quiet run ~20 s (the SCARF frames and the worker start-up)


def test_roberts_marks_a_diagonal_step_and_nothing_on_flat() -> None:
    a = np.zeros((6, 6), np.float32)
    a[:, 3:] = 10.0
    e = roberts(a)
    assert np.all(e[:-1, 2] == 20.0)  # both diagonals cross the step between columns 2 and 3
    assert np.all(e[:-1, [0, 1, 3, 4]] == 0.0)
    assert np.all(e[-1] == 0.0) and np.all(e[:, -1] == 0.0)


def test_texture_counts_textured_fine_pixels_and_ignores_brightness() -> None:
    rng = np.random.default_rng(1)
    img = np.full((240, 320, 3), 120, np.uint8)
    speckle = rng.integers(40, 200, (240, 160))
    img[:, 160:, 2] = speckle  # the right half textured (grass), the left half smooth (asphalt)
    t = texture_image(blue_pyramid(img, 60, 64))
    assert t.shape == (60, 64) and t.dtype == np.float32
    assert t[:59, :31].max() == 0.0  # smooth: nothing textured
    assert t[:59, 33:63].mean() > 12.0  # speckle: most of each 4×4 block
    # the same scene in a shadow 40 % as bright: the texture is the same (divided by the local brightness)
    dark = (img.astype(np.float32) * 0.4).round().astype(np.uint8)
    t_dark = texture_image(blue_pyramid(dark, 60, 64))
    assert abs(t_dark[:59, 33:63].mean() - t[:59, 33:63].mean()) < 1.0
    assert t_dark[:59, :31].max() == 0.0
    # without the brightness division a fixed edge threshold would lose the shaded speckle: the test can fail
    assert (roberts(blue_pyramid(dark, 60, 64).fine)[:236, 136:252] > 40.0).mean() < 0.6 * (
        roberts(blue_pyramid(img, 60, 64).fine)[:236, 136:252] > 40.0).mean()


def test_isodata_finds_three_colours_from_a_bad_start_and_keeps_k_classes() -> None:
    rng = np.random.default_rng(2)
    centres = np.array([[60.0, 60.0, 70.0], [120.0, 120.0, 125.0], [90.0, 140.0, 60.0]])
    x = np.vstack([rng.normal(c, 4.0, (300, 3)) for c in centres])
    start = np.zeros(len(x), np.int64)  # every pixel in one class: the others are empty
    lab = isodata(x, start, 3, iterations=4)
    found = np.array(sorted(x[lab == j].mean(axis=0).tolist() for j in range(3)))
    assert np.allclose(found, np.array(sorted(centres.tolist())), atol=2.0)
    # asked for four classes of three colours, it still returns four (one colour split), none empty
    lab4 = isodata(x, start, 4, iterations=4)
    assert sorted(np.bincount(lab4, minlength=4) > 0) == [True] * 4


def test_isodata_classes_separate_road_from_verge_and_texture_is_kept_from_the_bootstrap() -> None:
    rng = np.random.default_rng(3)
    img = np.empty((40, 40, 3))
    img[:, :20] = rng.normal((90, 90, 95), 5, (40, 20, 3))
    img[:, 20:] = rng.normal((80, 130, 60), 10, (40, 20, 3))
    road = np.zeros((40, 40), bool)
    road[:, :16] = True
    verge = np.zeros((40, 40), bool)
    verge[:, 24:] = True
    texture = np.where(np.arange(40)[None, :] < 20, 1.0, 9.0) * np.ones((40, 1))
    classes = isodata_classes(img, road, verge, k=2)
    assert classes is not None and len(classes.classes) == 4
    classes = attach_texture(classes, texture, road, verge)
    assert classify(img, classes, texture).p_road[:, :20].mean() > 0.95
    assert classify(img, classes, texture).p_road[:, 20:].mean() < 0.05
    again = attach_texture(isodata_classes(img * 0.6, road, verge, classes, k=2), np.zeros((40, 40)), road, verge, classes)
    assert {c.texture_mean for c in again.classes} == {1.0, 9.0}  # not adapted: the bootstrap's, not this frame's zeros
    # texture alone tells a grey verge from the road when the colours agree
    grey = np.full((40, 40, 3), 92.0) + rng.normal(0, 3, (40, 40, 3))
    same = ColourClasses(classes=tuple(c.model_copy(update={"mean": (92.0, 92.0, 92.0)}) for c in classes.classes))
    p = classify(grey, same, texture).p_road
    assert p[:, :20].mean() > 0.9 and p[:, 20:].mean() < 0.1


def test_scarf_over_workers_sees_what_one_process_sees_on_simulator_frames() -> None:
    from sidewalk.roadfollow_eval import plan_drive
    from tests.modules._road_frames import route_frames

    src = route_frames("north_hills")
    rng = np.random.default_rng(0)
    caps = [src.capture(p, rng) for p in plan_drive(src.legs, 8, rng, step_m=3.0)]
    cam = CameraGeometry.from_capture(caps[0])

    def run(pool, cfg):
        s = Scarf(cam, cfg, pool=pool)
        return [s.observe(c.camera_image, stamp=float(i)).model_dump(exclude={"ms_per_frame"}) for i, c in enumerate(caps)]

    for cfg in (ScarfConfig(), ScarfConfig(texture=True, colour_model="isodata")):
        alone = run(None, cfg)
        assert sum(o["found"] for o in alone) >= 7
        with VisionPool(3) as pool:
            assert run(pool, cfg) == alone
    assert math.isfinite(alone[-1]["lateral_offset_m"])
