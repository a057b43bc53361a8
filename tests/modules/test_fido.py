"""FIDO's library: known answers for the pyramid, the interest operator, pyramid correlation, triangulation and the
motion solver; stripes and split feature lists give the whole's results; a FIDO step on rendered campus images."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from modules.fido import (
    FidoConfig,
    MotionError,
    PlanarMotion,
    StereoGeometryError,
    StereoPair,
    StereoRig,
    build_pyramid,
    estimate_motion,
    fido_step,
    from_level,
    interest_map,
    pseudo_normalised_correlation,
    pyramid_correlate,
    select_features,
    stripe_alignment,
    to_level,
    triangulate,
    INTEREST_HALO,
)


def texture(size: int, seed: int, blur: float = 1.5) -> np.ndarray:
    """Return a smooth random grey texture (size, size) float32 [DN] with structure at every scale."""
    rng = np.random.default_rng(seed)
    out = np.zeros((size, size), np.float32)
    for s in (1, 4, 16, 64):  # octaves: fine grain up to blobs an eighth of the image wide
        n = rng.standard_normal((max(size // s, 2), max(size // s, 2))).astype(np.float32)
        out += cv2.resize(n, (size, size), interpolation=cv2.INTER_CUBIC) * np.float32(30.0)
    return cv2.GaussianBlur(out, (0, 0), blur) + np.float32(128.0)


def rig(size: int = 256, baseline: float = 0.5, f: float = 220.0) -> StereoRig:
    """Return a rectified rig: looking along vehicle +x from 1.5 m up, level."""
    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    T[:3, 3] = (0.5, 0.25, 1.5)
    K = np.array([[f, 0.0, (size - 1) / 2], [0.0, f, (size - 1) / 2], [0.0, 0.0, 1.0]])
    return StereoRig(K=K, baseline=baseline, T_vehicle_left=T, width=size, height=size)


# ---- pyramid -------------------------------------------------------------------------------------------------


def test_pyramid_has_seven_levels_of_2x2_means() -> None:
    im = texture(512, 0)
    pyr = build_pyramid(im)
    assert [p.shape for p in pyr] == [(512 >> k, 512 >> k) for k in range(7)]
    assert pyr[1][10, 20] == pytest.approx(im[20:22, 40:42].mean(), abs=1e-3)
    assert pyr[6][3, 5] == pytest.approx(im[192:256, 320:384].mean(), abs=1e-2)
    uv = np.array([[100.3, 37.0]])
    np.testing.assert_allclose(from_level(to_level(uv, 3), 3), uv)
    assert to_level(np.array([[1.5, 1.5]]), 1)[0] == pytest.approx([0.5, 0.5])  # the centre of pixels 0–3 … of block 0,1


def test_pyramid_of_aligned_stripes_is_the_whole_one_bit_for_bit() -> None:
    im = texture(512, 1)
    whole = build_pyramid(im)
    a = stripe_alignment()
    assert a == 64
    cuts = [0, 128, 192, 448, 512]  # stripes of different heights, each a multiple of 64
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        part = build_pyramid(im[lo:hi], 7)
        for k in range(7):
            np.testing.assert_array_equal(part[k], whole[k][lo >> k:hi >> k])


# ---- interest operator ---------------------------------------------------------------------------------------


def test_interest_operator_peaks_at_a_corner_not_on_edges() -> None:
    im = np.full((80, 100), 50.0, np.float32)
    im[30:, 40:] = 200.0  # a bright quadrant: one corner at (row 30, col 40), edges along row 30 and col 40
    iv = interest_map(im)
    r, c = np.unravel_index(np.argmax(iv), iv.shape)
    assert abs(r - 29.5) <= 1 and abs(c - 39.5) <= 1
    assert iv[30, 70] == 0.0 and iv[60, 40] == 0.0 and iv[10, 10] == 0.0  # along an edge one direction sees no change
    pts = select_features(iv, grid=10, min_interest=1.0)
    assert len(pts.uv) >= 1 and np.linalg.norm(pts.uv[0] - (c, r)) == 0.0
    assert np.all(np.diff(pts.interest) <= 0)  # by decreasing interest


def test_interest_features_are_the_grid_maxima_and_respect_exclusion() -> None:
    iv = np.zeros((100, 100), np.float32)
    iv[5, 5], iv[7, 8], iv[55, 52], iv[95, 95] = 10.0, 20.0, 30.0, 5.0
    pts = select_features(iv, grid=10, min_interest=6.0)
    np.testing.assert_array_equal(pts.uv, [[52, 55], [8, 7]])  # (u, v); the cell at (5, 5) has a bigger one; 5 ≤ 6
    pts = select_features(iv, grid=10, min_interest=0.0, exclude=np.array([[50.0, 50.0]]), min_separation=8.0)
    assert [tuple(p) for p in pts.uv] == [(8, 7), (95, 95)]


def test_interest_on_overlapping_stripes_is_the_whole_bit_for_bit() -> None:
    im = texture(200, 2, blur=0.8)
    whole = interest_map(im)
    h = INTEREST_HALO
    for axis in (0, 1):  # horizontal and vertical stripes (the Warp's were vertical)
        cuts = [0, 37, 90, 150, 200]
        parts = []
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            a, b = max(lo - h, 0), min(hi + h, im.shape[axis])
            sub = interest_map(np.take(im, range(a, b), axis=axis))
            parts.append(np.take(sub, range(lo - a, lo - a + hi - lo), axis=axis))
        np.testing.assert_array_equal(np.concatenate(parts, axis=axis), whole)


# ---- correlation ---------------------------------------------------------------------------------------------


def test_pseudo_normalised_correlation_is_the_papers_formula() -> None:
    rng = np.random.default_rng(3)
    t = rng.uniform(0, 255, (1, 4, 4))
    area = rng.uniform(0, 255, (1, 8, 8))
    area[0, 2:6, 3:7] = t[0] + 17.0  # the template, brighter, at row 2, column 3
    corr = pseudo_normalised_correlation(t, area)
    assert np.unravel_index(np.argmax(corr[0]), (5, 5)) == (2, 3)
    assert corr[0, 2, 3] == pytest.approx(1.0)
    I = area[0, 1:5, 0:4]  # position (1, 0) by hand
    s1, s2, st = I.sum(), (I ** 2).sum(), (t[0] * I).sum()
    expect = (st - t.mean() * s1) / (t.var() + (s2 - s1 ** 2 / 16) / 16) / 8
    assert corr[0, 1, 0] == pytest.approx(expect)
    half = area.copy()
    half[0, 2:6, 3:7] = 0.5 * t[0]  # the pattern at half the contrast scores lower: pseudo-normalised, not normalised
    assert pseudo_normalised_correlation(t, half)[0, 2, 3] == pytest.approx(2 * 0.5 / (1 + 0.25))
    flat = np.full((1, 8, 8), 9.0)
    assert np.all(pseudo_normalised_correlation(np.full((1, 4, 4), 3.0), flat) == 0.0)


@pytest.mark.parametrize("level", range(6))
def test_pyramid_correlation_recovers_a_known_shift_at_every_level(level: int) -> None:
    """A texture moved by (du, dv) px is found again exactly by a search that starts at `level`; each shift is beyond the
    reach of a start one level finer (±2 px at the start level and at every finer one: ±2·(2^(L+1) − 1) px)."""
    size = 256
    big = texture(size + 200, 4)
    du, dv = [(1, -1), (3, -4), (-8, 6), (17, -13), (-38, 25), (70, 10)][level]
    src = big[100:100 + size, 100:100 + size]
    dst = big[100 - dv:100 - dv + size, 100 - du:100 - du + size]  # dst(u + du, v + dv) = src(u, v)
    ps, pd = build_pyramid(src, 6), build_pyramid(dst, 6)
    g = np.array([-30.0, -10.0, 10.0, 30.0])
    uv = np.array([(128 - du // 2 + a, 128 - dv // 2 + b) for a in g for b in g])  # the features and their matches central
    m = pyramid_correlate(ps, pd, uv, top_level=level, subpixel=False)
    exact = np.all(m.uv == uv + (du, dv), axis=1)
    kept = m.interior & (m.score > 0.95)  # what FIDO accepts: a peak inside the level-0 search area
    assert exact[kept].all() and kept.sum() >= 15, (m.uv - uv, m.score, m.interior)
    if level:
        finer = pyramid_correlate(ps, pd, uv, top_level=level - 1, subpixel=False)
        assert not np.any(np.all(finer.uv == uv + (du, dv), axis=1))


def test_the_subpixel_peak_lessens_the_error_of_a_half_pixel_shift() -> None:
    src = texture(256, 8, blur=1.0)
    dst = cv2.warpAffine(src, np.float32([[1, 0, 0.5], [0, 1, 0.5]]), (256, 256), flags=cv2.INTER_CUBIC)  # (+½, +½) px
    ps, pd = build_pyramid(src, 6), build_pyramid(dst, 6)
    g = np.linspace(40, 210, 8)
    uv = np.array([(u, v) for u in g for v in g])
    whole = np.linalg.norm(pyramid_correlate(ps, pd, uv, subpixel=False).uv - (uv + 0.5), axis=1)
    sub = np.linalg.norm(pyramid_correlate(ps, pd, uv).uv - (uv + 0.5), axis=1)
    assert np.median(whole) == pytest.approx(math.sqrt(0.5), abs=1e-6)
    assert np.median(sub) < 0.7 * np.median(whole)


def test_correlation_of_split_feature_lists_is_the_whole() -> None:
    src, dst = texture(128, 5), np.roll(texture(128, 5), (3, -4), axis=(0, 1))
    ps, pd = build_pyramid(src, 5), build_pyramid(dst, 5)
    uv = np.random.default_rng(0).uniform(10, 118, (37, 2))
    whole = pyramid_correlate(ps, pd, uv)
    parts = [pyramid_correlate(ps, pd, uv[a:b]) for a, b in ((0, 5), (5, 20), (20, 37))]
    np.testing.assert_array_equal(np.concatenate([p.uv for p in parts]), whole.uv)
    np.testing.assert_array_equal(np.concatenate([p.score for p in parts]), whole.score)


# ---- triangulation -------------------------------------------------------------------------------------------


def test_triangulation_of_projected_points_gives_their_depth() -> None:
    r = rig()
    pts = np.array([[4.0, 0.3, 0.2], [12.0, -2.0, 1.1], [30.0, 5.0, 0.0]])
    ul, ok_l = r.project(pts, "left")
    ur, ok_r = r.project(pts, "right")
    assert ok_l.all() and ok_r.all() and np.allclose(ul[:, 1], ur[:, 1])
    sp = triangulate(r, ul, ur)
    np.testing.assert_allclose(sp.xyz, pts, atol=1e-9)
    np.testing.assert_allclose(sp.depth, pts[:, 0] - 0.5, atol=1e-9)  # along the optical axis = vehicle x − 0.5
    # the error grows with Z² along the ray: σ_Z = Z²·σ/(f·b)·√2
    sig_along = np.sqrt(sp.cov[:, 0, 0])
    np.testing.assert_allclose(sig_along[2] / sig_along[0], (29.5 / 3.5) ** 2, rtol=0.05)
    bad = triangulate(r, ur, ul)  # swapped: negative disparity, not a point
    assert not bad.valid.any() and np.isinf(bad.depth).all()


@pytest.mark.parametrize(("depth", "subpixel"), [(2.75, False), (5.5, False), (11.0, False), (7.5, True), (15.0, True)])
def test_a_synthetic_pair_matched_by_fido_gives_the_known_depth(depth: float, subpixel: bool) -> None:
    """A textured wall at a known depth: the right image is the left moved by the disparity f·b/Z; FIDO's stereo finds Z
    (exactly for whole-pixel disparities 40, 20 and 10 px; to 2 % for 14.7 and 7.3 px with the parabola's refinement)."""
    r = rig()
    d = r.focal * r.baseline / depth  # [px]
    wall = texture(256 + 128, 6, blur=1.0)
    shift = np.float32([[1, 0, -d], [0, 1, 0]])  # right(u) = left(u + d)
    left = wall[:256, 64:320]
    right = cv2.warpAffine(wall, shift, (wall.shape[1], wall.shape[0]), flags=cv2.INTER_CUBIC)[:256, 64:320]
    pair = StereoPair(left=np.ascontiguousarray(left), right=np.ascontiguousarray(right), stamp=0.0)
    step = fido_step(pair, r, config=FidoConfig(levels=6, grid=8, min_interest=0.0, subpixel=subpixel))
    f = step.features
    assert len(f) >= 30
    assert np.median(f.depth) == pytest.approx(depth, rel=0.02 if subpixel else 1e-9)
    assert np.mean(np.abs(f.depth - depth) < 0.05 * depth) > 0.9


def test_rig_from_a_capture_refuses_an_unrectified_or_missing_pair() -> None:
    class Cap:
        pass

    r = rig()
    c = Cap()
    c.stereo_K, c.T_vehicle_stereo_left = r.K, r.T_vehicle_left
    right = r.T_vehicle_left.copy()
    right[:3, 3] -= right[:3, :3] @ [-0.5, 0.0, 0.0]  # 0.5 m along the left camera's +x
    c.T_vehicle_stereo_right, c.stereo_left = right, np.zeros((256, 256, 3), np.uint8)
    assert StereoRig.from_capture(c).baseline == pytest.approx(0.5)
    c.T_vehicle_stereo_right = right.copy()
    c.T_vehicle_stereo_right[:3, :3] = cv2.Rodrigues(np.array([0.0, 0.02, 0.0]))[0] @ right[:3, :3]
    with pytest.raises(StereoGeometryError, match="not parallel"):
        StereoRig.from_capture(c)
    c.T_vehicle_stereo_right = r.T_vehicle_left.copy()
    c.T_vehicle_stereo_right[:3, 3] += [0.0, 0.0, 0.3]  # above, not beside
    with pytest.raises(StereoGeometryError, match="along the left"):
        StereoRig.from_capture(c)
    with pytest.raises(StereoGeometryError, match="missing"):
        StereoRig.from_capture(Cap())
    with pytest.raises(StereoGeometryError, match="missing"):
        StereoPair.from_capture(Cap())


# ---- motion --------------------------------------------------------------------------------------------------


def test_motion_from_noisy_points_with_outliers() -> None:
    rng = np.random.default_rng(7)
    r = rig()
    true = PlanarMotion(1.02, -0.04, math.radians(2.5))
    prev = np.column_stack([rng.uniform(3, 25, 40), rng.uniform(-6, 6, 40), rng.uniform(0, 2.5, 40)])
    now = true.to_current(prev)
    ul, _ = r.project(now, "left")
    ur, _ = r.project(now, "right")
    pl, _ = r.project(prev, "left")
    pr, _ = r.project(prev, "right")
    s = 0.3  # [px] of image noise
    a = triangulate(r, pl + rng.normal(0, s, pl.shape), pr + rng.normal(0, s, pr.shape), pixel_sigma=s)
    b = triangulate(r, ul + rng.normal(0, s, ul.shape), ur + rng.normal(0, s, ur.shape), pixel_sigma=s)
    bxyz = b.xyz.copy()
    bxyz[[3, 11, 29]] += [[0.0, 1.5, 0.0], [-2.0, 0.0, 0.5], [0.0, 0.0, 1.0]]  # three tracks jumped to other points
    m = estimate_motion(a.xyz, a.cov, bxyz, b.cov)
    assert m.dx == pytest.approx(true.dx, abs=0.02) and m.dy == pytest.approx(true.dy, abs=0.02)
    assert m.dyaw == pytest.approx(true.dyaw, abs=math.radians(0.1)) and abs(m.dz) < 0.02
    assert not m.inliers[[3, 11, 29]].any() and m.inliers.sum() >= 34
    with pytest.raises(MotionError, match="consistent"):
        estimate_motion(a.xyz[:2], a.cov[:2], b.xyz[:2], b.cov[:2])


# ---- a FIDO step on the simulator's images -------------------------------------------------------------------


@pytest.mark.timeout(120)  # quiet run ~12 s
def test_fido_on_rendered_campus_steps_finds_depth_and_motion_despite_a_wrong_odometry() -> None:
    """Six 1 m steps along the south walk: depth against the renderer's true depth, motion against the true poses,
    with an odometry prior that is off by 5 % in distance, 2 cm sideways and 0.7° a step (it only guides the search)."""
    from vehicle_sim.scene import Scene
    from vehicle_sim.sensors import CaptureRequest, capture
    from vehicle_sim.worldfile import load_world

    scene = Scene(load_world("campus"), seed=0)
    req = CaptureRequest(laser=False, camera=False, stereo=True)
    memory, est = None, np.zeros(3)
    poses = [(6.0 + k, -0.75, math.radians(0.5 * (-1) ** k)) for k in range(6)]
    errs = []
    for k, pose in enumerate(poses):
        cap = capture(scene, pose, 2.0 * k, req, vehicle="terregator", rng=np.random.default_rng(k))
        odo = PlanarMotion(1.05, 0.02, math.radians(-0.7)) if memory is not None else None
        step = fido_step(StereoPair.from_capture(cap), StereoRig.from_capture(cap), memory, odometry=odo)
        memory = step.memory
        f = step.features
        ul = np.rint(f.uv_left).astype(int)
        truth = cap.stereo_depth_true[ul[:, 1], ul[:, 0]]
        near = np.isfinite(truth) & (truth < 10.0)
        errs += list(np.abs(f.depth - truth)[near])
        if k:
            assert step.motion is not None, step.motion_failure
            assert f.tracked.sum() >= 8
            m = step.motion
            c, s = math.cos(est[2]), math.sin(est[2])
            est = est + [c * m.dx - s * m.dy, s * m.dx + c * m.dy, m.dyaw]
    assert len(errs) > 100 and np.median(errs) < 0.15
    d = np.array(poses[-1][:2]) - poses[0][:2]
    c0, s0 = math.cos(poses[0][2]), math.sin(poses[0][2])
    moved = np.array([c0 * d[0] + s0 * d[1], -s0 * d[0] + c0 * d[1]])  # in the first vehicle frame
    assert np.linalg.norm(est[:2] - moved) < 0.02 * 5.0  # within 2 % of the 5 m driven
    assert abs(est[2] - (poses[-1][2] - poses[0][2])) < math.radians(0.5)
