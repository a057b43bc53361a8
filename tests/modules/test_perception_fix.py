"""Synthetic tests of the OBJECT FINDER, POSITION CALIBRATOR and PERCEPTION MONITOR."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Polygon

from modules.perception.calibrator import CalibrationError, EdgeObservation, PointObservation, calibrate
from modules.perception.monitor import (
    ResolutionTable,
    SensorGeometry,
    image_input_position,
    segmentation_params,
    select_segmentation,
)
from modules.perception.object_finder import find_objects
from modules.perception.patch_maker import Segmentation, make_patches, SurfaceType
from modules.perception.predicted import predict, vehicle_to_world, world_to_vehicle
from modules.vocabulary import MapColour, MapObject, SlopeShape, StairsShape, TreeShape

GRAY = MapColour(type="GRAY", nominal=(128.0, 128.0, 126.0))
GREEN = MapColour(type="GREEN", nominal=(70.0, 125.0, 55.0))


def _ring(poly: Polygon) -> np.ndarray:
    return np.asarray(poly.exterior.coords)[:-1]


def _densify(ring: np.ndarray, step: float = 0.3) -> np.ndarray:
    out = []
    for a, b in zip(ring, np.roll(ring, -1, axis=0)):
        n = max(1, int(np.linalg.norm(b - a) / step))
        for t in np.arange(n) / n:
            out.append(a + t * (b - a))
    return np.asarray(out)


def _normals(ring: np.ndarray) -> np.ndarray:
    pts = []
    for a, b in zip(ring, np.roll(ring, -1, axis=0)):
        n = max(1, int(np.linalg.norm(b - a) / 0.3))
        d = (b - a) / np.linalg.norm(b - a)
        pts += [np.array([d[1], -d[0]])] * n
    return np.asarray(pts)


def _observe(world_polys: list[Polygon], truth: tuple[float, float, float], rng: np.random.Generator):
    obs = []
    for poly in world_polys:
        ring = _ring(poly)
        if Polygon(ring).exterior.is_ccw is False:
            ring = ring[::-1]
        pts_w = _densify(ring)
        pts_v = world_to_vehicle(pts_w, truth) + rng.normal(0, 0.03, pts_w.shape)
        yaw = truth[2]
        c, s = math.cos(-yaw), math.sin(-yaw)
        nv = _normals(ring) @ np.array([[c, -s], [s, c]]).T
        obs.append(EdgeObservation(points=pts_v, normals=nv, polygon=ring))
    return obs


def test_calibrator_recovers_a_known_pose_offset() -> None:
    rng = np.random.default_rng(3)
    truth = (10.0, 5.0, math.radians(30.0))
    # an intersection: two crossing sidewalks give corners in two directions
    polys = [Polygon([(12, 3), (22, 3), (22, 6), (12, 6)]), Polygon([(15, -2), (18, -2), (18, 12), (15, 12)])]
    obs = _observe(polys, truth, rng)
    prior = (truth[0] + 0.8, truth[1] - 0.6, truth[2] + math.radians(3.0))
    res = calibrate(obs, [], prior)
    assert res.kind == "point"
    assert math.hypot(res.pose[0] - truth[0], res.pose[1] - truth[1]) < 0.05
    assert abs(res.pose[2] - truth[2]) < math.radians(0.3)
    assert np.all(np.linalg.eigvalsh(res.covariance) > 0)
    assert math.sqrt(res.covariance[0, 0]) < 0.1


def test_parallel_edges_give_a_line_along_the_sidewalk() -> None:
    rng = np.random.default_rng(4)
    truth = (0.0, 0.0, math.radians(10.0))
    # a long straight sidewalk along the heading: the view shows only its two parallel edges
    d = np.array([math.cos(truth[2]), math.sin(truth[2])])
    n = np.array([-d[1], d[0]])
    obs = []
    poly = np.array([-50 * d - 1.5 * n, 50 * d - 1.5 * n, 50 * d + 1.5 * n, -50 * d + 1.5 * n])
    for off, sign in ((-1.5, -1.0), (1.5, 1.0)):
        pts_w = np.array([t * d + off * n for t in np.linspace(3, 12, 30)])
        pts_v = world_to_vehicle(pts_w, truth) + rng.normal(0, 0.02, pts_w.shape)
        nv = np.tile(world_to_vehicle(np.array([sign * n]), (0, 0, truth[2])), (30, 1))
        obs.append(EdgeObservation(points=pts_v, normals=nv, polygon=poly))
    prior = (truth[0] + 0.5 * d[0] + 0.4 * n[0], truth[1] + 0.5 * d[1] + 0.4 * n[1], truth[2] + math.radians(2))
    res = calibrate(obs, [], prior)
    assert res.kind == "line"
    assert res.yaw_known
    ang = abs(((res.line_direction - truth[2]) + math.pi / 2) % math.pi - math.pi / 2)
    assert ang < math.radians(2.0)
    lateral = abs(np.dot(np.array(res.pose[:2]) - truth[:2], n))
    assert lateral < 0.05  # across the sidewalk the fix is exact
    assert abs(res.pose[2] - truth[2]) < math.radians(0.5)


def test_a_single_tree_gives_a_line_without_heading() -> None:
    truth = (3.0, -2.0, math.radians(-20.0))
    tree = (10.0, 1.0)
    seen = tuple(world_to_vehicle(np.array([tree]), truth)[0])
    prior = (truth[0] + 0.3, truth[1] + 0.2, truth[2] + math.radians(2))
    res = calibrate([], [PointObservation(point=seen, target=tree)] * 2, prior)
    assert res.kind == "line" and not res.yaw_known
    # the line is the tangent of the circle around the tree through the vehicle
    radial = np.array(tree) - np.array(res.pose[:2])
    assert abs(math.cos(res.line_direction) * radial[0] + math.sin(res.line_direction) * radial[1]) / np.linalg.norm(radial) < 0.1


def test_calibrator_with_nothing_in_reach_raises() -> None:
    far = Polygon([(100, 100), (101, 100), (101, 101)])
    obs = [EdgeObservation(points=np.array([[1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]), normals=None, polygon=_ring(far))]
    with pytest.raises(CalibrationError):
        calibrate(obs, [], (0.0, 0.0, 0.0))


def _objects():
    slope = MapObject(object_id="slope1", kind="slope", role="path", cost=1.0, colour=GRAY,
                      shape=SlopeShape(rise=1.5, axis_deg=0.0), polygon=((6, -1), (16, -1), (16, 1), (6, 1)))
    stairs = MapObject(object_id="stairs1", kind="stairs", role="path", cost=3.0, colour=GRAY,
                       shape=StairsShape(rise=1.5, axis_deg=0.0, step_rise=0.15), polygon=((6, 1), (10, 1), (10, 4), (6, 4)))
    grass = MapObject(object_id="grass1", kind="grass", role="none", colour=GREEN, polygon=((6, -5), (16, -5), (16, -1), (6, -1)))
    tree = MapObject(object_id="tree1", kind="tree", role="landmark", colour=GREEN,
                     shape=TreeShape(trunk_radius=0.2, crown_radius=2.0, height=6.0, crown_base=2.5), center=(12.0, 5.0), radius=2.0)
    return [slope, stairs, grass, tree]


def test_object_finder_matches_by_symbol_then_geometry() -> None:
    h, w = 60, 60
    rows, cols = np.mgrid[0:h, 0:w]
    xy = np.stack([6.0 + 0.2 * (h - rows), 6.0 - 0.2 * cols], axis=-1).astype(np.float32)  # x 6..18, y 6..-6
    valid = np.ones((h, w), bool)
    y = xy[..., 1]
    x = xy[..., 0]
    labels = np.zeros((h, w), int)
    labels[(np.abs(y) < 1)] = 1  # grey tilted → slope
    labels[(y >= 1) & (y < 4) & (x < 10)] = 2  # grey rough → stairs
    labels[(y < -1) & (y > -5)] = 3  # green flat → grass
    labels[(y >= 1) & (y < 4) & (x >= 10)] = 4  # grey flat → nothing predicted there
    colour_of = {1: "GRAY", 2: "GRAY", 3: "GREEN", 4: "GRAY"}
    surface_of = {1: SurfaceType.TILTED, 2: SurfaceType.ROUGH, 3: SurfaceType.FLAT, 4: SurfaceType.FLAT}
    ps = make_patches(labels, xy, valid, colour_of=colour_of, surface_of=surface_of, min_area_m2=0.5)
    prior = (0.3, -0.2, math.radians(1.0))
    found, wm = find_objects(ps, predict(_objects(), prior), allowance=0.5)
    got = {f.predicted.obj.object_id: f for f in found}
    assert set(got) == {"slope1", "stairs1", "grass1"}
    assert got["slope1"].patches[0].label == 1 and got["stairs1"].patches[0].label == 2
    unmatched = {p.label for p in ps.patches} - {p.label for f in found for p in f.patches}
    assert unmatched == {4}


def test_monitor_selects_segmentation_by_object_shape() -> None:
    objs = _objects()
    assert select_segmentation([objs[2]]) is Segmentation.COLOUR
    assert select_segmentation([objs[2], objs[3]]) is Segmentation.COLOUR  # a tree beside a lawn: still flat ground
    assert select_segmentation(objs[:3]) is Segmentation.COLORED_RANGE
    p = segmentation_params(objs)
    assert 2.0 <= p.range.flat_max_deg <= 6.0  # half the predicted slope tilt (8.5 deg)
    assert p.range.rough_sigma == pytest.approx(0.6 * 0.15 / math.sqrt(12), rel=1e-6)
    assert p.min_area_m2 <= 0.1  # a tree is predicted: small segments matter


def test_resolution_table_trades_distance_for_time() -> None:
    t = ResolutionTable(SensorGeometry(height=2.3, pitch_down=math.radians(14.0)))
    d_fine, d_coarse = t.distance_for(0.3, 1), t.distance_for(0.3, 4)
    assert d_fine > d_coarse  # finer resolution sees farther for the same error allowance
    assert t.distance_for(1.0, 1) >= t.distance_for(0.3, 1)
    plan = t.plan(0.3)
    assert plan.speed == pytest.approx(plan.distance / plan.time_s)
    # at a modest speed every step is fast enough: the monitor takes the widest view (fine resolution)
    slow_drive = t.plan(0.3, speed=1.0)
    assert slow_drive.step == 1 and slow_drive.distance == pytest.approx(d_fine)
    # when the fine resolution is measured slow, the monitor goes short-sighted and coarse (Figure 9)
    t.record(1, 5.0)
    t.record(2, 5.0)
    fast_drive = t.plan(0.3, speed=5.0)
    assert fast_drive.step == 4 and fast_drive.distance <= slow_drive.distance
    table = t.table(speed=1.0)
    assert [p.error_allowance for p in table] == sorted(p.error_allowance for p in table)
    assert [p.distance for p in table] == sorted(p.distance for p in table)


def test_image_input_position_is_where_the_view_frame_first_covers_the_region() -> None:
    path = np.array([[0.0, 0.0], [40.0, 0.0]])
    region = Polygon([(20, -1.5), (24, -1.5), (24, 1.5), (20, 1.5)])
    view = ((3.0, -2.5), (12.0, -10.0), (12.0, 10.0), (3.0, 2.5))
    pos = image_input_position(path, region, view, step=0.25)
    assert pos.coverage > 0.85
    # the far edge of the view (12 m) must reach beyond most of the region (24 m): s ≈ 12
    assert 11.0 <= pos.arc_length <= 12.5
    assert pos.pose[2] == pytest.approx(0.0)


def test_frames_round_trip() -> None:
    pose = (3.0, -1.0, 0.7)
    pts = np.array([[1.0, 2.0], [-4.0, 0.5]])
    np.testing.assert_allclose(world_to_vehicle(vehicle_to_world(pts, pose), pose), pts, atol=1e-12)
