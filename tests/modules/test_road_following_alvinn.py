"""ALVINN: shifted views match the moved camera, the corrected steering is the geometry's, a tiny net learns, weights files."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.road_following import (
    Alvinn, AlvinnModelError, AlvinnNet, AlvinnShape, CameraGeometry, arc_road_point, decode_steering, moved_line,
    pursuit_curvature, retina, shifted_view, steering_targets, training_views,
)


@pytest.fixture(scope="module")
def hills():
    from tests.modules._road_frames import route_frames

    return route_frames("north_hills")


@pytest.mark.parametrize("dy,dyaw_deg", [(0.0, 0.0), (0.8, 0.0), (-0.5, 4.0), (0.3, -6.0)])
def test_corrected_steering_is_what_the_geometry_implies(dy: float, dyaw_deg: float) -> None:
    L = 12.0
    a = math.radians(dyaw_deg)
    road = np.stack([np.linspace(-10.0, 60.0, 71), np.zeros(71)], 1)  # a straight road centre along x
    got = pursuit_curvature(moved_line(road, dy, a), L)
    # closed form: the moved vehicle sees the centre line through R(−a)·(t, −dy); |(t, −dy)| = L ahead
    t = math.sqrt(L * L - dy * dy)
    y = -t * math.sin(a) - dy * math.cos(a)
    assert got == pytest.approx(2.0 * y / (L * L), abs=2e-4)
    # the arc of that curvature meets the road centre L ahead: the seed's road point
    rp = np.asarray(arc_road_point(got, L))
    assert np.hypot(*rp) == pytest.approx(L, rel=1e-6)
    q = moved_line(road, dy, a)
    assert np.min(np.hypot(q[:, 0] - rp[0], q[:, 1] - rp[1])) < 0.6  # on the centre line (sampled every 1 m)


def test_shifted_view_matches_the_camera_moved_there(hills) -> None:
    from sidewalk.roadfollow_eval import DrivePose

    rng = np.random.default_rng(1)
    base = DrivePose(leg=0, x=0.0, y=10.0, yaw=math.pi / 2, stamp=5.0)
    dy, a = 0.7, math.radians(4.0)
    # the moved vehicle: dy to its left (west on Oak St, heading north) and turned by a
    moved = DrivePose(leg=0, x=-dy, y=10.0, yaw=math.pi / 2 + a, stamp=5.0)
    (fa, cap), (fb, _) = list(hills.frames([base, moved], rng))
    cam = CameraGeometry.from_capture(cap)
    synth = shifted_view(fa.image, cam, dy, a)
    near = int(cam.horizon_row) + 20  # ground rows, clear of the horizon's far-away detail
    err_synth = np.abs(synth[near:].astype(float) - fb.image[near:]).mean()
    err_plain = np.abs(fa.image[near:].astype(float) - fb.image[near:]).mean()
    assert err_synth < 0.5 * err_plain
    r_synth, r_b, r_a = retina(synth), retina(fb.image), retina(fa.image)
    assert np.abs(r_synth - r_b).mean() < 0.5 * np.abs(r_a - r_b).mean()


def test_a_tiny_net_learns_to_steer_from_a_few_frames(hills, tmp_path) -> None:
    from sidewalk.roadfollow_eval import DrivePose, to_vehicle
    from sidewalk.cli._roadfollow import _centre_ahead

    rng = np.random.default_rng(2)
    poses = [DrivePose(leg=0, x=float(rng.uniform(-0.3, 0.3)), y=-30.0 + 4.0 * i, yaw=math.pi / 2, stamp=float(i)) for i in range(30)]
    shape = AlvinnShape(hidden=4)
    xs, ks = [], []
    for fr, cap in hills.frames(poses, rng):
        cam = CameraGeometry.from_capture(cap)
        x, k = training_views(fr.image, cam, _centre_ahead(to_vehicle(fr.centre_world, fr.pose)), rng, views=10)
        xs.append(x)
        ks.append(k)
    test = [3, 11, 19, 27]  # held-out images, spread along the road
    x_tr, k_tr = np.concatenate([x for i, x in enumerate(xs) if i not in test]), np.concatenate([k for i, k in enumerate(ks) if i not in test])
    x_te, k_te = np.concatenate([xs[i] for i in test]), np.concatenate([ks[i] for i in test])
    net = AlvinnNet(shape, rng)
    losses = net.train(x_tr, steering_targets(k_tr, shape), rng, epochs=150)
    assert losses[-1] < 0.5 * losses[0]
    pred, conf = decode_steering(net.forward(x_te), shape)
    assert np.median(np.abs(pred - k_te)) < 0.5 * np.median(np.abs(k_te - np.median(k_tr)))
    # the weights round-trip through an npz file and drive the follower
    path = net.save(tmp_path / "alvinn.npz")
    alv = Alvinn.from_file(cam, path)
    obs = alv.observe(fr.image, stamp=1.0)
    assert obs.method == "alvinn" and obs.steering_curvature_per_m is not None and obs.road_point is not None
    assert obs.steering_curvature_per_m == pytest.approx(float(decode_steering(net.forward(retina(fr.image)[None]), shape)[0][0]))


def test_weights_files_that_cannot_be_used_are_named(tmp_path) -> None:
    with pytest.raises(AlvinnModelError, match="no such file"):
        AlvinnNet.load(tmp_path / "missing.npz")
    bad = tmp_path / "other.npz"
    np.savez(bad, w1=np.zeros(3))
    with pytest.raises(AlvinnModelError, match=r"other\.npz.*missing b1"):
        AlvinnNet.load(bad)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(AlvinnModelError, match="junk.npz"):
        AlvinnNet.load(junk)
