"""Capture: projections of known points, labels against geometry, seeds, registration, wire codec."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from tests.vehicle_sim.test_scene import box, look, synthetic_world
from vehicle_sim.scene import Scene
from vehicle_sim.sensors import (
    CaptureDecodeError,
    CaptureRequest,
    capture,
    decode_capture,
    encode_capture,
    extrinsics_for,
    illumination_gain,
    project,
    register,
    world_from_vehicle,
)
from vehicle_sim.sensors.camera import CameraConfig
from vehicle_sim.sensors.laser import LaserConfig
from vehicle_sim.worldfile import KINDS, FlatShape, WorldObject
from wire.capture import TRUTH_FIELDS

MARK = WorldObject(id="mark", kind="intersection", role="path", cost=1.0, **look((200.0, 40.0, 40.0), (3.0, 3.0, 3.0), "RED"),
                   shape=FlatShape(), polygon=box(7.0, -0.9, 7.6, -0.3))


@pytest.fixture(scope="module")
def world():
    return synthetic_world(extra=(MARK,))


@pytest.fixture(scope="module")
def scene(world):
    return Scene(world, seed=5)


def _vehicle_point(pose, p_world):
    x, y, yaw = pose
    return world_from_vehicle(x, y, yaw).inverse().apply(np.asarray(p_world, float))


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (0.5, -1.5, math.radians(10.0))])
def test_known_ground_point_projects_to_expected_pixel(scene, pose) -> None:
    res = capture(scene, pose, 1.0, vehicle="navlab", rng=np.random.default_rng(0))
    ext = extrinsics_for("navlab")
    p = _vehicle_point(pose, [7.3, -0.6, 0.0])  # the centre of the red mark on the ground
    # laser: azimuth/elevation from the scanner → pixel (col 0 = +40°, row 0 = top)
    d = p - np.asarray(ext.laser_position)
    az, el = math.atan2(d[1], d[0]), math.atan2(d[2], math.hypot(d[0], d[1]))
    cfg = LaserConfig()
    col = int(round((0.5 - math.degrees(az) / cfg.hfov_deg) * cfg.cols - 0.5))
    row = int(round((0.5 - (math.degrees(el) - cfg.tilt_deg) / cfg.vfov_deg) * cfg.rows - 0.5))
    assert KINDS[res.laser_labels[row, col]] == "intersection"
    assert res.laser_range_true[row, col] == pytest.approx(np.linalg.norm(d), abs=0.1)
    # camera: pinhole by hand (optical axis pitched down, x right = -y_vehicle)
    pitch = math.radians(ext.camera_pitch_deg)
    z_c = np.array([math.cos(pitch), 0.0, -math.sin(pitch)])
    x_c = np.array([0.0, -1.0, 0.0])
    y_c = np.cross(z_c, x_c)
    dc = p - np.asarray(ext.camera_position)
    K = res.camera_K
    u = K[0, 2] + K[0, 0] * (dc @ x_c) / (dc @ z_c)
    v = K[1, 2] + K[1, 1] * (dc @ y_c) / (dc @ z_c)
    assert KINDS[res.camera_labels[int(round(v)), int(round(u))]] == "intersection"
    uv, inside = project(p[None], ext.camera_from_vehicle, K, (res.camera_image.shape[1], res.camera_image.shape[0]))
    assert inside[0] and np.allclose(uv[0], [u, v], atol=1e-6)
    # and the camera sees it red
    patch = res.camera_image[int(round(v)) - 1:int(round(v)) + 2, int(round(u)) - 1:int(round(u)) + 2].reshape(-1, 3).mean(0)
    assert patch[0] > patch[1] + 60


def test_labels_agree_with_geometry(scene, world) -> None:
    pose = (1.0, 0.5, math.radians(5.0))
    res = capture(scene, pose, 0.0, rng=np.random.default_rng(1))
    pts_v = (np.asarray(res.T_vehicle_laser[:3, 3]) + _laser_dirs(res) * np.nan_to_num(res.laser_range_true, posinf=0.0)[..., None].astype(float))
    hit = np.isfinite(res.laser_range_true)
    pw = world_from_vehicle(*pose).apply(pts_v[hit])
    lab = res.laser_labels[hit]
    ground = np.isin(lab, [KINDS.index(k) for k in ("grass", "sidewalk", "slope", "stairs", "intersection")])
    agree = world.label_at(pw[ground, :2]) == lab[ground]
    assert agree.mean() > 0.97
    flat = ground & (lab != KINDS.index("stairs"))  # stair risers sit between two tread heights
    assert (np.abs(pw[flat, 2] - world.elevation(pw[flat, :2])) < 0.02).mean() > 0.99
    hall = shapely.Polygon(world.object("hall").polygon).exterior
    b = lab == KINDS.index("building")
    assert b.sum() > 20
    assert max(hall.distance(shapely.Point(x, y)) for x, y in pw[b, :2]) < 0.02
    mb = lab == KINDS.index("mailbox")
    assert mb.sum() > 3
    r = np.hypot(pw[mb, 0] - 6.0, pw[mb, 1] - 2.2)
    assert np.all(r < 0.25 + 0.02) and np.all(pw[mb, 2] < 1.1 + 0.02)
    # camera labels: the same classes appear, sky at the top, ground at the bottom
    assert KINDS[res.camera_labels[0, 160]] == "sky" and KINDS[res.camera_labels[-1, 160]] in ("sidewalk", "grass")


def _laser_dirs(res):
    az, el = res.laser_az.astype(float), res.laser_el.astype(float)
    ce = np.cos(el)[:, None]
    return np.stack([ce * np.cos(az)[None], ce * np.sin(az)[None], np.broadcast_to(np.sin(el)[:, None], ce.shape[:1] + az.shape)], -1)


def test_laser_xyz_is_the_measured_range_along_the_ray(scene) -> None:
    res = capture(scene, (0.0, 0.0, 0.0), 0.0, rng=np.random.default_rng(2))
    v = res.laser_valid
    back = np.linalg.norm(res.laser_xyz[v] - res.T_vehicle_laser[:3, 3], axis=1)
    np.testing.assert_allclose(back, res.laser_range[v], atol=1e-4)
    assert np.isnan(res.laser_xyz[~v]).all()


def test_same_seed_same_frames(scene) -> None:
    pose = (2.0, 0.0, 0.1)
    a = capture(scene, pose, 12.5, rng=np.random.default_rng(42))
    b = capture(scene, pose, 12.5, rng=np.random.default_rng(42))
    c = capture(scene, pose, 12.5, rng=np.random.default_rng(43))
    for name in ("laser_code", "laser_reflectance", "camera_image", "colored_range", "camera_labels"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.camera_image, c.camera_image)
    assert not np.array_equal(a.laser_code, c.laser_code)
    np.testing.assert_array_equal(a.camera_labels, c.camera_labels)  # truth does not depend on noise
    # without an rng the noise derives from the scene seed and the stamp
    d = capture(scene, pose, 12.5)
    e = capture(Scene(synthetic_world(extra=(MARK,)), seed=5), pose, 12.5)
    np.testing.assert_array_equal(d.camera_image, e.camera_image)
    np.testing.assert_array_equal(d.laser_code, e.laser_code)


def test_camera_rendered_beside_the_laser_is_the_sequential_render(scene) -> None:
    """Both sensors at once (the camera renders on a side thread) give exactly the frames of one sensor after the other."""
    pose = (0.5, -1.5, math.radians(10.0))
    both = capture(scene, pose, 3.0, rng=np.random.default_rng(11))
    g = np.random.default_rng(11)  # the laser draws first, then the camera's noise
    laser = capture(scene, pose, 3.0, CaptureRequest(camera=False), rng=g)
    camera = capture(scene, pose, 3.0, CaptureRequest(laser=False), rng=g)
    for name in ("laser_code", "laser_range", "laser_valid", "laser_reflectance", "laser_labels", "laser_mixed"):
        assert np.array_equal(getattr(both, name), getattr(laser, name)), name
    assert np.array_equal(both.camera_image, camera.camera_image)
    assert np.array_equal(both.camera_labels, camera.camera_labels)
    other = capture(scene, pose, 3.0, CaptureRequest(laser=False), rng=np.random.default_rng(11))
    assert not np.array_equal(other.camera_image, both.camera_image)  # the noise does depend on the draws before it


def test_registration_maps_a_known_point_to_its_camera_pixel() -> None:
    ext = extrinsics_for("navlab")
    K = np.array([[200.0, 0.0, 159.5], [0.0, 200.0, 119.5], [0.0, 0.0, 1.0]])
    p = np.array([9.0, 1.2, 0.3])  # vehicle frame
    dc = ext.camera_from_vehicle.apply(p)
    u, v = 159.5 + 200.0 * dc[0] / dc[2], 119.5 + 200.0 * dc[1] / dc[2]
    image = np.zeros((240, 320, 3), np.uint8)
    image[int(round(v)) - 1:int(round(v)) + 2, int(round(u)) - 1:int(round(u)) + 2] = (255, 0, 0)
    xyz = np.full((4, 5, 3), np.nan, np.float32)
    xyz[2, 3] = p
    xyz[1, 1] = (-5.0, 0.0, 1.0)  # behind the camera
    valid = ~np.isnan(xyz[..., 0])
    cr = register(xyz, valid, image, ext.camera_from_vehicle, K)
    assert tuple(cr.colour[2, 3]) == (255, 0, 0)
    np.testing.assert_allclose(cr.uv[2, 3], [u, v], atol=1e-3)
    assert cr.valid[2, 3] and not cr.valid[1, 1] and not cr.valid[0, 0]
    assert (cr.colour[~cr.valid] == 0).all()


def test_colored_range_carries_the_camera_colour_of_each_laser_point(scene) -> None:
    res = capture(scene, (0.0, 0.0, 0.0), 0.0, rng=np.random.default_rng(3))
    ok = res.colored_range_valid
    assert ok.mean() > 0.6  # the camera covers the scanner's field of view
    uv = np.round(res.colored_range_uv[ok]).astype(int)
    cam_lab = res.camera_labels[np.clip(uv[:, 1], 0, 239), np.clip(uv[:, 0], 0, 319)]
    same = cam_lab == res.laser_labels[ok]
    assert same.mean() > 0.9  # mismatches only at parallax edges and wrapped (far) ranges
    red = res.laser_labels == KINDS.index("intersection")
    assert red.any() and (res.colored_range[red & ok][:, 0].astype(int) - res.colored_range[red & ok][:, 1] > 60).mean() > 0.8


def test_stairs_and_slope_differ_in_range_not_in_colour(scene, world) -> None:
    res = capture(scene, (2.0, 0.0, 0.0), 0.0, rng=np.random.default_rng(4))
    pts = world_from_vehicle(2.0, 0.0, 0.0).apply(
        np.asarray(res.T_vehicle_laser[:3, 3]) + _laser_dirs(res) * np.nan_to_num(res.laser_range_true, posinf=0.0)[..., None].astype(float))
    stairs = res.laser_labels == KINDS.index("stairs")
    slope = res.laser_labels == KINDS.index("slope")
    assert stairs.sum() > 100 and slope.sum() > 100
    # slope: every point on one plane z = 0.15 (x - 10)
    zs = pts[slope]  # (the synthetic ramp is a raised wedge: its side faces are off the plane)
    assert (np.abs(zs[:, 2] - 0.15 * np.clip(zs[:, 0] - 10.0, 0, 10)) < 0.02).mean() > 0.95
    # stairs: treads at multiples of 0.15 m plus vertical risers between them (points off every tread)
    zt = pts[stairs][:, 2]
    off_tread = np.abs(zt / 0.15 - np.round(zt / 0.15)) * 0.15 > 0.02
    assert off_tread.mean() > 0.05
    # a plane fit leaves steps on the stairs but not on the slope
    def plane_residual(p):
        A = np.column_stack([p[:, 0], p[:, 1], np.ones(len(p))])
        coef, *_ = np.linalg.lstsq(A, p[:, 2], rcond=None)
        return np.abs(A @ coef - p[:, 2]).mean()
    assert plane_residual(pts[stairs]) > 3 * plane_residual(pts[slope])
    # colour: the same grey statistics (means within a few DN), while grass is clearly different
    cam = res.camera_image.reshape(-1, 3).astype(float)
    lab = res.camera_labels.ravel()
    m_st = cam[lab == KINDS.index("stairs")].mean(0)
    m_sl = cam[lab == KINDS.index("slope")].mean(0)
    m_gr = cam[lab == KINDS.index("grass")].mean(0)
    assert np.abs(m_st - m_sl).max() < 15.0
    assert np.abs(m_gr - m_sl).max() > 40.0


def test_tree_shadow_darkens_the_sidewalk_in_the_camera(scene) -> None:
    pose = (0.0, 0.0, 0.0)
    res = capture(scene, pose, 0.0, rng=np.random.default_rng(5))
    ext = extrinsics_for("navlab")
    K = res.camera_K
    along = np.array([math.sin(math.radians(20.0)), math.cos(math.radians(20.0))])
    shade = np.array([8.0, -3.0]) + 4.0 * along  # on the walk, inside the crown's shadow (see test_scene)
    lit = np.array([shade[0] - 4.0, shade[1]])  # the same walk 4 m nearer, in the sun
    vals = []
    for q in (shade, lit):
        uv, inside = project(np.array([[q[0], q[1], 0.0]]), ext.camera_from_vehicle, K, (320, 240))
        assert inside[0]
        u, v = np.round(uv[0]).astype(int)
        assert KINDS[res.camera_labels[v, u]] == "sidewalk"
        vals.append(res.camera_image[v - 1:v + 2, u - 1:u + 2].reshape(-1, 3).astype(float).mean(0))
    ratio = vals[0].mean() / vals[1].mean()
    assert 0.3 < ratio < 0.6  # the skylight-only ratio (0.42) with texture and noise


def test_illumination_drifts_slowly() -> None:
    cfg = CameraConfig()
    g = np.array([illumination_gain(t, cfg) for t in np.arange(0.0, 240.0, 1.0)])
    assert g.max() - g.min() > 0.15 and np.abs(np.diff(g)).max() < 0.01


def test_wire_roundtrip_and_bad_payloads(scene) -> None:
    res = capture(scene, (1.0, 0.0, 0.2), 3.0, CaptureRequest(camera_width=160, camera_height=120), vehicle="terregator",
                  rng=np.random.default_rng(6))
    assert res.camera_image.shape == (120, 160, 3) and res.camera_labels.shape == (120, 160)
    back = decode_capture(encode_capture(res, truth=True))
    for name, val in vars(res).items():
        if isinstance(val, np.ndarray):
            np.testing.assert_array_equal(getattr(back, name), val)
            assert getattr(back, name).dtype == val.dtype
        else:
            assert getattr(back, name) == val
    plain = decode_capture(encode_capture(res))  # no truth unless asked for
    assert all(getattr(plain, name) is None for name in TRUTH_FIELDS)
    np.testing.assert_array_equal(plain.camera_image, res.camera_image)
    only = capture(scene, (1.0, 0.0, 0.2), 3.0, CaptureRequest(camera=False))
    back = decode_capture(encode_capture(only))
    assert back.camera_image is None and back.colored_range is None and back.laser_code.shape == (64, 256)
    with pytest.raises(CaptureDecodeError, match="not msgpack"):
        decode_capture(b"\xc1garbage")
    import msgpack

    d = msgpack.unpackb(encode_capture(res, truth=True), raw=False)
    d["arrays"]["laser_range"]["data"] = d["arrays"]["laser_range"]["data"][:-4]
    with pytest.raises(CaptureDecodeError, match="laser_range"):
        decode_capture(msgpack.packb(d, use_bin_type=True))
    d = msgpack.unpackb(encode_capture(res), raw=False)
    d["arrays"]["camera_image"]["dtype"] = "float32"
    with pytest.raises(CaptureDecodeError, match="camera_image"):
        decode_capture(msgpack.packb(d, use_bin_type=True))
    d = msgpack.unpackb(encode_capture(res), raw=False)
    del d["stamp"]
    with pytest.raises(CaptureDecodeError, match="stamp"):
        decode_capture(msgpack.packb(d, use_bin_type=True))


def test_bad_pose_and_vehicle_are_rejected(scene) -> None:
    with pytest.raises(ValueError, match="finite"):
        capture(scene, (float("nan"), 0.0, 0.0), 0.0)
    with pytest.raises(ValueError, match="unknown vehicle"):
        capture(scene, (0.0, 0.0, 0.0), 0.0, vehicle="bicycle")
