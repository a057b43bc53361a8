"""SCARF: the triangle vote recovers a road, colour classes separate road from verge, branches are found, real frames."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.road_following import (
    CameraGeometry, ColourClass, ColourClasses, Scarf, TriangleRoad, best_triangle, classify, estimate_classes,
    find_branches, triangle_in_vehicle, triangle_mask,
)


def _triangle_image(rng: np.random.Generator, truth: TriangleRoad, shape=(60, 64), flip: float = 0.2) -> np.ndarray:
    """Votes (2·P(road) − 1) of a classified image: the true triangle, with `flip` of the pixels misclassified."""
    road = triangle_mask(shape, truth)
    p = np.where(road, rng.uniform(0.6, 1.0, shape), rng.uniform(0.0, 0.4, shape))
    wrong = rng.random(shape) < flip
    p[wrong] = 1.0 - p[wrong]
    # a block of shadowed verge that looks like road, beside the road
    p[40:55, 50:60] = 0.9
    return 2.0 * p - 1.0


@pytest.mark.parametrize("apex,skew_deg", [(20.0, 25.0), (41.5, -18.0), (33.0, 0.0)])
def test_vote_recovers_a_synthetic_triangle_road(apex: float, skew_deg: float) -> None:
    rng = np.random.default_rng(int(apex * 10))
    truth = TriangleRoad(apex_col=apex, skew_rad=math.radians(skew_deg), horizon_row=18.3, half_width_rate=0.9)
    weight = _triangle_image(rng, truth)
    apex_cols = np.arange(-60.0, 124.0, 0.5)
    skews = np.radians(np.arange(-60.0, 60.5, 1.0))
    got = best_triangle(weight, truth.horizon_row, truth.half_width_rate, apex_cols, skews)
    assert abs(got.apex_col - apex) <= 1.0
    assert abs(math.degrees(got.skew_rad) - skew_deg) <= 1.5
    # the winner beats a road 10 columns off, and the votes are what the triangle holds
    off = weight[triangle_mask(weight.shape, truth.model_copy(update={"apex_col": apex + 10}))].sum()
    assert got.votes > off
    assert got.votes == pytest.approx(weight[triangle_mask(weight.shape, got)].sum(), rel=0.05)


def test_colour_classes_tell_road_from_verge_and_follow_a_shift() -> None:
    rng = np.random.default_rng(3)
    img = np.empty((40, 40, 3))
    img[:, :20] = rng.normal((90, 90, 95), 6, (40, 20, 3))  # asphalt
    img[:, 20:] = rng.normal((80, 130, 60), 12, (40, 20, 3))  # grass
    road = np.zeros((40, 40), bool)
    road[:, :16] = True
    verge = np.zeros((40, 40), bool)
    verge[:, 24:] = True
    classes = estimate_classes(img, road, verge, k=2)
    assert classes is not None and len(classes.classes) == 4
    cl = classify(img, classes)
    assert cl.p_road[:, :20].mean() > 0.95 and cl.p_road[:, 20:].mean() < 0.05
    # the sun goes in: everything 40 % darker; re-estimated from the old classes' road, they follow
    dark = img * 0.6
    again = estimate_classes(dark, road, verge, classes, k=2)
    assert again is not None
    assert classify(dark, again).p_road[:, :20].mean() > 0.95
    # a class set that is wrong (road and verge swapped) gives the wrong answer: the test can fail
    swapped = ColourClasses(classes=tuple(c.model_copy(update={"road": not c.road}) for c in classes.classes))
    assert classify(img, swapped).p_road[:, :20].mean() < 0.05


def _camera() -> CameraGeometry:
    f = 0.5 * 320 / math.tan(math.radians(40.0))
    p = math.radians(12.0)
    opt = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    ry = np.array([[math.cos(p), 0.0, math.sin(p)], [0.0, 1.0, 0.0], [-math.sin(p), 0.0, math.cos(p)]])
    T = np.eye(4)
    T[:3, :3] = ry @ opt
    T[:3, 3] = (1.5, 0.1, 2.5)
    return CameraGeometry(width=320, height=240, K=((f, 0.0, 159.5), (0.0, f, 119.5), (0.0, 0.0, 1.0)),
                          T_vehicle_camera=tuple(map(tuple, T)))


def test_branch_search_finds_the_side_road_of_a_t_junction() -> None:
    cam = _camera().scaled(64, 60)
    g = cam.ground_grid
    x, y = g[..., 0], g[..., 1]
    main = np.abs(y - 0.4) <= 3.0
    side = (np.abs(x - 18.0) <= 3.0) & (y > 0.4)  # a road leaving to the left 18 m ahead
    p = np.where(main | side, 0.9, 0.1)
    p[~np.isfinite(x)] = 0.0
    branches = find_branches(p, g, 0.4, 0.0, 6.0)
    assert len(branches) == 1
    assert abs(math.degrees(branches[0].angle_rad) - 90.0) <= 10.0
    assert abs(branches[0].along_m - 18.0) <= 3.0
    assert branches[0].probability > 0.5
    # no side road: nothing is accepted
    assert find_branches(np.where(main, 0.9, 0.1), g, 0.4, 0.0, 6.0) == ()


def test_scarf_finds_the_road_on_north_hills_from_an_off_bootstrap() -> None:
    from sidewalk.roadfollow_eval import DrivePose, centre_at_origin, to_vehicle
    from tests.modules._road_frames import route_frames

    src = route_frames("north_hills")
    rng = np.random.default_rng(0)
    poses = [DrivePose(leg=0, x=0.9, y=-30.0 + 3.0 * i, yaw=math.pi / 2 + math.radians(3.0), stamp=float(i)) for i in range(6)]
    scarf = None
    for fr, cap in src.frames(poses, rng):
        if scarf is None:  # bootstrap 1 m off: SCARF must move to the road, not keep its prior
            scarf = Scarf(CameraGeometry.from_capture(cap), prior_lateral_m=0.1)
        obs = scarf.observe(fr.image, stamp=fr.pose.stamp)
    truth = centre_at_origin(to_vehicle(fr.centre_world, fr.pose))
    assert truth is not None and abs(truth[0] - 0.1) > 0.7
    assert obs.found and obs.confidence > 0.5
    assert abs(obs.lateral_offset_m - truth[0]) < 0.3
    assert abs(math.degrees(obs.heading_rad - truth[1])) < 3.0
    assert obs.ms_per_frame > 0.0


def test_triangle_in_vehicle_is_the_inverse_of_the_prior_triangle() -> None:
    cam = _camera()
    s = Scarf(cam, prior_lateral_m=-1.2, prior_heading_rad=math.radians(5.0))
    lat, hd = triangle_in_vehicle(s._prior_triangle(), s.small)
    assert lat == pytest.approx(-1.2, abs=0.05)
    assert math.degrees(hd) == pytest.approx(5.0, abs=0.3)
