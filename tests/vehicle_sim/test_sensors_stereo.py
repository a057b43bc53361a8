"""FIDO's stereo pair: a rectified pair whose disparities are f·b/Z, true depth beside it, served like the other sensors."""

from __future__ import annotations

import math

import msgpack
import numpy as np
import pytest

from tests.vehicle_sim.test_scene import box, look, synthetic_world
from vehicle_sim.scene import Scene
from vehicle_sim.sensors import (
    CaptureDecodeError,
    CaptureRequest,
    StereoConfig,
    capture,
    decode_capture,
    encode_capture,
    stereo_mount_for,
    world_from_vehicle,
)
from vehicle_sim.worldfile import KINDS, FlatShape, WorldObject
from wire.capture import TRUTH_FIELDS

#: a red square on the ground, 8–9 m ahead and to the left of a vehicle at the origin
MARK = WorldObject(id="mark", kind="intersection", role="path", cost=1.0, **look((210.0, 30.0, 30.0), (2.0, 2.0, 2.0), "RED"),
                   shape=FlatShape(), polygon=box(8.0, 0.4, 9.0, 1.4))
STEREO = CaptureRequest(laser=False, camera=False, stereo=True, stereo_size=256)


@pytest.fixture(scope="module")
def scene():
    return Scene(synthetic_world(extra=(MARK,)), seed=7)


def _pixel(T: np.ndarray, K: np.ndarray, p_vehicle: np.ndarray) -> tuple[np.ndarray, float]:
    """Return (u, v) and depth Z [m] of a vehicle-frame point in the camera `vehicle ← camera` T (by hand)."""
    c = T[:3, :3].T @ (p_vehicle - T[:3, 3])
    return np.array([K[0, 0] * c[0] / c[2] + K[0, 2], K[1, 1] * c[1] / c[2] + K[1, 2]]), float(c[2])


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (0.4, -0.3, math.radians(6.0))])
def test_a_ground_point_lies_on_one_row_at_the_disparity_of_its_depth(scene, pose) -> None:
    res = capture(scene, pose, 2.0, STEREO, vehicle="terregator", rng=np.random.default_rng(1))
    p = world_from_vehicle(*pose).inverse().apply(np.array([8.5, 0.9, 0.0]))  # the mark's centre
    ul, z = _pixel(res.T_vehicle_stereo_left, res.stereo_K, p)
    ur, zr = _pixel(res.T_vehicle_stereo_right, res.stereo_K, p)
    mount = stereo_mount_for("terregator")
    assert ul[1] == pytest.approx(ur[1], abs=1e-9) and z == pytest.approx(zr, abs=1e-9)  # rectified
    assert ul[0] - ur[0] == pytest.approx(res.stereo_K[0, 0] * mount.baseline / z, rel=1e-9)
    iu, iv = (int(round(c)) for c in ul)
    assert KINDS[res.stereo_labels[iv, iu]] == "intersection"
    assert res.stereo_depth_true[iv, iu] == pytest.approx(z, rel=0.02)
    for img, uv in ((res.stereo_left, ul), (res.stereo_right, ur)):  # both cameras see it red
        u, v = (int(round(c)) for c in uv)
        rgb = img[v - 1:v + 2, u - 1:u + 2].reshape(-1, 3).mean(axis=0)
        assert rgb[0] > 3 * rgb[1] + 20  # (the mark may lie in a shadow)
    assert res.stereo_left.shape == res.stereo_right.shape == (256, 256, 3)


def test_true_depth_is_sky_above_and_ground_below_with_edges_unknown(scene) -> None:
    res = capture(scene, (0.0, 0.0, 0.0), 2.0, STEREO, vehicle="terregator", rng=np.random.default_rng(1))
    z = res.stereo_depth_true
    sky = res.stereo_labels == KINDS.index("sky")
    assert sky[0].mean() > 0.5 and np.isinf(z[sky]).mean() > 0.95 and not np.isinf(z[~sky]).any()
    ground = z[-1]
    h = res.T_vehicle_stereo_left[2, 3]
    pitch = math.asin(-res.T_vehicle_stereo_left[2, 2])  # the optical axis points down by the pitch
    # the bottom row looks down by pitch + half the vertical field of view: flat ground at that depth
    down = pitch + math.atan((z.shape[0] - 1) / 2 / res.stereo_K[1, 1])
    assert np.nanmedian(ground) == pytest.approx(h * math.cos(down - pitch) / math.sin(down), rel=0.02)
    edges = np.isnan(z)
    assert 0 < edges.mean() < 0.05  # only where a pixel straddles two surfaces


def test_the_pair_leaves_the_other_sensors_as_they_were(scene) -> None:
    pose = (1.0, 0.5, 0.1)
    plain = capture(scene, pose, 4.0, rng=np.random.default_rng(9))
    both = capture(scene, pose, 4.0, CaptureRequest(stereo=True, stereo_size=128), rng=np.random.default_rng(9))
    for name in ("laser_code", "laser_reflectance", "camera_image", "colored_range"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(both, name))
    assert plain.stereo_left is None and both.stereo_left.shape == (128, 128, 3)
    again = capture(scene, pose, 4.0, CaptureRequest(stereo=True, stereo_size=128), rng=np.random.default_rng(9))
    np.testing.assert_array_equal(again.stereo_right, both.stereo_right)  # reproducible from the seed


def test_wire_carries_the_pair_and_its_truth_only_when_asked(scene) -> None:
    res = capture(scene, (0.0, 0.0, 0.0), 1.0, STEREO, vehicle="navlab", rng=np.random.default_rng(3))
    back = decode_capture(encode_capture(res, truth=True))
    for name in ("stereo_left", "stereo_right", "stereo_K", "T_vehicle_stereo_left", "T_vehicle_stereo_right",
                 "stereo_labels", "stereo_depth_true"):
        np.testing.assert_array_equal(getattr(back, name), getattr(res, name))
    plain = decode_capture(encode_capture(res))
    assert {"stereo_labels", "stereo_depth_true"} <= set(TRUTH_FIELDS)
    assert plain.stereo_depth_true is None and plain.stereo_labels is None and plain.stereo_left is not None
    d = msgpack.unpackb(encode_capture(res), raw=False)
    del d["arrays"]["stereo_right"]
    with pytest.raises(CaptureDecodeError, match="stereo_right"):
        decode_capture(msgpack.packb(d, use_bin_type=True))
    d = msgpack.unpackb(encode_capture(res), raw=False)
    d["arrays"]["stereo_K"]["shape"] = [9]
    with pytest.raises(CaptureDecodeError, match="stereo_K"):
        decode_capture(msgpack.packb(d, use_bin_type=True))


def test_bad_stereo_sizes_are_refused() -> None:
    for bad in (100, 32, 4096):
        with pytest.raises(ValueError, match="stereo_size"):
            CaptureRequest(stereo=True, stereo_size=bad)
    assert StereoConfig().size == 512  # the paper's 512×512
