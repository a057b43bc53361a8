"""PERCEPTION on the simulator's real captures: wire decoding, registration, the paper's claim on the
slope/stairs/grass scene, driving-unit results, and the evaluation command.

PERCEPTION is told what the robot would be told: the shipped map (offset, rotated and scattered
against the world) and a prior pose that is off by about 1 m and a few degrees."""

from __future__ import annotations

import json
import math

import msgpack
import numpy as np
import pytest
from typer.testing import CliRunner

from sidewalk.perception_eval import oracle_labels, IouAccumulator
from modules.perception.patch_maker import Segmentation
from modules.perception.pipeline import PerceptionPipeline
from modules.perception.results import build_result
from modules.perception.sensor_frame import SensorFrame, SensorFrameError, colored_range_image, decode_sensor_frame, sensor_geometry
from modules.vocabulary import DrivingUnitDescription
from sidewalk.cli import app
from sidewalk.cli._perception import FrameSource, objects_in_view
from vehicle_sim.sensors import capture, encode_capture


@pytest.fixture(scope="module")
def src() -> FrameSource:
    return FrameSource("campus", vehicle="terregator", seed=1)  # objects from the shipped map, not the world


def _off(truth, dx=0.8, dy=-0.6, dyaw_deg=3.0):
    """Return a prior pose off the truth by (dx, dy) [m] (world frame) and `dyaw_deg` [deg]."""
    return (truth[0] + dx, truth[1] + dy, truth[2] + math.radians(dyaw_deg))


def _frame(src: FrameSource, pose, seed=0):
    res = capture(src.scene, pose, 1.0, src.request, vehicle=src.vehicle, rng=np.random.default_rng(seed))
    return res


def test_wire_round_trip_and_registration(src: FrameSource) -> None:
    res = _frame(src, (0.0, -28.0, math.pi / 2))
    frame = decode_sensor_frame(encode_capture(res))
    np.testing.assert_array_equal(frame.laser_range, res.laser_range)
    assert frame.range_step == pytest.approx(res.range_step)
    geom = sensor_geometry(frame)
    assert geom.height == pytest.approx(1.6) and geom.rows == 64 and geom.cols == 256
    img = colored_range_image(frame)
    # registered colour agrees with the simulator's own registration where both exist
    both = img.valid & res.colored_range_valid
    assert both.mean() > 0.4
    diff = np.abs(img.rgb[both] - res.colored_range[both].astype(np.float32))
    assert np.median(diff) < 3.0
    # ground points lie on the ground, and nothing beyond one ambiguity interval is kept
    flat = img.valid & (np.abs(img.xyz[..., 2]) < 0.3)
    assert flat.mean() > 0.3
    horiz = np.hypot(img.xyz[..., 0] - 0.7, img.xyz[..., 1])
    assert horiz[img.valid].max() <= frame.ambiguity + 1e-3


def test_bad_capture_payloads_say_what_is_wrong(src: FrameSource) -> None:
    with pytest.raises(SensorFrameError, match="not msgpack"):
        decode_sensor_frame(b"\xc1garbage")
    with pytest.raises(SensorFrameError, match="format"):
        decode_sensor_frame(msgpack.packb({"format": "other"}))
    good = msgpack.unpackb(encode_capture(_frame(src, (0.0, -28.0, math.pi / 2))), raw=False)
    del good["arrays"]["laser_range"]
    with pytest.raises(SensorFrameError, match="laser_range"):
        decode_sensor_frame(msgpack.packb(good, use_bin_type=True))
    good = msgpack.unpackb(encode_capture(_frame(src, (0.0, -28.0, math.pi / 2))), raw=False)
    good["arrays"]["laser_valid"]["shape"] = [32, 512]
    with pytest.raises(SensorFrameError, match="laser_valid"):
        decode_sensor_frame(msgpack.packb(good, use_bin_type=True))


def test_colored_range_separates_slope_stairs_and_grass(src: FrameSource) -> None:
    """Sidewalk 1986 §3.4.5 on the campus scene: the fused labels beat colour alone and range alone."""
    k = len(src.kinds)
    pipe = PerceptionPipeline(src.table)
    accs = {m: IouAccumulator(k) for m in Segmentation}
    # the intersection below the stairs and the slope, looking up at both with the grass between
    for pose in [(61.0, 56.0, math.radians(80)), (62.0, 58.0, math.radians(95)), (63.5, 57.0, math.radians(88))]:
        res = _frame(src, pose)
        img = colored_range_image(SensorFrame.from_fields(res))
        labels = res.laser_labels.astype(np.int64)
        labels[(labels == src.kinds.index("sky")) | (labels == src.kinds.index("none"))] = -1
        prior = _off(pose, 0.5, -0.6, 2.0)
        objs = objects_in_view(src, prior)
        scored = img.valid & (labels >= 0)
        for m in Segmentation:
            model = pipe.colour_model_for(objs) if m is not Segmentation.RANGE else None  # fresh: the map's nominal colours
            seg = pipe.segment(img, objs, prior, m, error_allowance=1.0, model=model)
            accs[m].add(oracle_labels(seg.patches.ids, labels, scored, k), labels, scored)
    idx = [src.kinds.index(c) for c in ("slope", "stairs", "grass")]
    mean = {m: float(np.mean(accs[m].iou()[idx])) for m in Segmentation}
    assert mean[Segmentation.COLORED_RANGE] > mean[Segmentation.COLOUR] + 0.1
    assert mean[Segmentation.COLORED_RANGE] > mean[Segmentation.RANGE] + 0.1
    iou = {m: accs[m].iou() for m in Segmentation}
    grass, slope = src.kinds.index("grass"), src.kinds.index("slope")
    assert iou[Segmentation.RANGE][grass] < iou[Segmentation.COLORED_RANGE][grass]  # range merges the grass bank with the slope
    assert iou[Segmentation.COLOUR][slope] < iou[Segmentation.COLORED_RANGE][slope]  # colour merges grey slope, stairs, walks


def test_driving_unit_result_on_a_real_frame(src: FrameSource) -> None:
    truth = (0.0, -24.0, math.pi / 2)
    res = _frame(src, truth)
    img = colored_range_image(SensorFrame.from_fields(res))
    prior = _off(truth)  # 0.8 m across the walk, 0.6 m back, 3° left
    objs = tuple(o for o in objects_in_view(src, prior) if o.shape.type == "flat")  # the walk and its lawn, as mapped
    walk = next(o for o in objs if o.object_id == "sw_dorm")
    mapped_x = float(np.mean([x for x, y in walk.polygon if abs(y + 24.0) < 30.0]))
    unit = DrivingUnitDescription(unit_id="s.u0", segment_id="s", unit_index=0, mode="follow-road",
                                  region=((-1.5, -18.0), (1.5, -18.0), (1.5, -12.0), (-1.5, -12.0)),
                                  centreline=((0.0, -18.0), (0.0, -12.0)), objects=objs, error_allowance_m=1.2)
    out = PerceptionPipeline(src.table).process(img, objs, prior, error_allowance=1.2)
    result = build_result(unit, out, prior, res.stamp, img)
    assert result.status == "perceived" and result.sensor == "colour"
    assert result.fix is not None and result.fix.kind == "line"  # a straight sidewalk: only parallel edges
    assert abs(result.fix.direction % math.pi - math.pi / 2) < math.radians(2.0)
    # across the walk the fix comes back from 0.8 m to the truth, up to the map's own offset of the walk
    assert abs(result.fix.point[0] - truth[0]) < 0.15 + abs(mapped_x - truth[0]) < abs(prior[0] - truth[0])
    assert result.fix.yaw is not None and abs(result.fix.yaw - truth[2]) < math.radians(1.0)


def test_eval_command_prints_the_report() -> None:
    out = CliRunner().invoke(app, ["perception", "eval", "--world", "campus", "--frames", "4", "--seed", "2", "--json"])
    assert out.exit_code == 0, out.output
    r = json.loads(out.output)
    assert r["frames"] == 4
    assert set(r["iou_all"]) == {"colour", "range", "colored_range"}
    assert r["cycle_ms_p50"] > 0 and "point" in r["position_fix"]
    bad = CliRunner().invoke(app, ["perception", "eval", "--world", "nowhere", "--frames", "1"])
    assert bad.exit_code != 0 and "nowhere" in bad.output


def test_objects_without_colour_fall_back_to_range(src: FrameSource) -> None:
    truth = (0.0, -24.0, math.pi / 2)
    res = _frame(src, truth)
    img = colored_range_image(SensorFrame.from_fields(res))
    prior = _off(truth)
    objs = tuple(o.model_copy(update={"colour": None}) for o in objects_in_view(src, prior) if o.shape.type == "flat")
    out = PerceptionPipeline(src.table).process(img, objs, prior, error_allowance=1.2)
    assert out.method is Segmentation.RANGE
    # range alone cannot tell the flat walk from the flat lawn around it (§3.4.5): the unit says so
    assert "no predicted path object found" in out.failure


def test_a_degenerate_navigable_region_fails_the_unit_with_a_reason(src: FrameSource) -> None:
    """A sliver or a self-touching outline never reaches the blackboard as a polygon (it used to crash PERCEPTION)."""
    from dataclasses import replace

    from shapely.geometry import Polygon as ShapelyPolygon

    from blackboard import Polygon as BbPolygon
    from modules.perception.results import world_ring

    truth = (0.0, -24.0, math.pi / 2)
    res = _frame(src, truth)
    img = colored_range_image(SensorFrame.from_fields(res))
    prior = _off(truth)
    objs = tuple(o for o in objects_in_view(src, prior) if o.shape.type == "flat")
    unit = DrivingUnitDescription(unit_id="s.u0", segment_id="s", unit_index=0, mode="follow-road",
                                  region=((-1.5, -18.0), (1.5, -18.0), (1.5, -12.0), (-1.5, -12.0)),
                                  centreline=((0.0, -18.0), (0.0, -12.0)), objects=objs, error_allowance_m=1.2)
    out = PerceptionPipeline(src.table).process(img, objs, prior, error_allowance=1.2)
    assert out.navigable is not None and not out.failure
    # a sliver: three almost collinear vertices (zero area once rounded)
    sliver = ShapelyPolygon([(1.0, 0.0), (5.0, 0.00001), (9.0, 0.0)])
    failed = build_result(unit, replace(out, navigable=sliver), prior, res.stamp, img)
    assert failed.status == "failed" and "degenerate" in failed.failure_reason
    assert failed.navigable_region is None and failed.fix is None
    # a bow tie (self-intersecting) is repaired to its larger simple part, which the blackboard accepts
    bowtie = ShapelyPolygon([(1.0, -1.0), (6.0, 1.0), (6.0, -1.0), (1.0, 1.5)])
    ring = world_ring(bowtie, prior)
    assert ring is not None
    BbPolygon(points=ring)
    ok = build_result(unit, replace(out, navigable=bowtie), prior, res.stamp, img)
    assert ok.status == "perceived" and ok.navigable_region is not None
    BbPolygon(points=ok.navigable_region)
