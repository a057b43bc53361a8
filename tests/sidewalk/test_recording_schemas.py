"""Recordings without a network: the JSON schemas of the channels, the Foxglove message shapes, the MCAP file."""

from __future__ import annotations

import json
import math

import jsonschema
import msgpack
import pytest

from modules.vocabulary import (
    DrivingUnitDescription, ExitCondition, LocalPathPlan, MissionStatus, PerceptionResult, PlanPose, RoutePlan,
    RouteSegmentDescription,
)
from sidewalk.recording import RecordingError, open_recording
from sidewalk.recording.channels import decode_payload, family_of, jsonable, topic_of
from sidewalk.recording.derive import derive_sample, derive_token, map_scene
from sidewalk.recording.foxglove import FOXGLOVE_MODELS, foxglove_schema, frame_transform, yaw_quaternion
from sidewalk.recording.schemas import token_schema
from sidewalk.recording.sink import McapSink, to_json_bytes
from wire.drive import SimClock, TruthPose, encode
from wire.health import Heartbeat, encode_heartbeat
from wire.preview import PreviewImage, SimPreview, encode_preview

# Foxglove's published field names (docs.foxglove.dev, "Message schemas"), by message.
FOXGLOVE_FIELDS = {
    "foxglove.FrameTransform": {"timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"},
    "foxglove.SceneUpdate": {"deletions", "entities"},
    "foxglove.CompressedImage": {"timestamp", "frame_id", "data", "format"},
    "foxglove.GeoJSON": {"geojson"},
}
SCENE_ENTITY_FIELDS = {"timestamp", "frame_id", "id", "lifetime", "frame_locked", "metadata", "arrows", "cubes", "spheres",
                       "cylinders", "lines", "triangles", "texts", "models"}
LINE_FIELDS = {"type", "pose", "thickness", "scale_invariant", "points", "color", "colors", "indices"}


def _refs(node) -> list:
    if isinstance(node, dict):
        return (["$ref"] if "$ref" in node else []) + [r for v in node.values() for r in _refs(v)]
    if isinstance(node, list):
        return [r for v in node for r in _refs(v)]
    return []


@pytest.mark.parametrize("name", sorted(FOXGLOVE_MODELS))
def test_foxglove_schemas_have_foxglove_fields_and_no_references(name):
    s = foxglove_schema(name)
    assert s["title"] == name and s["type"] == "object"
    assert set(s["properties"]) == FOXGLOVE_FIELDS[name]
    assert not _refs(s) and "$defs" not in json.dumps(s)
    if "timestamp" in s["properties"]:
        ts = s["properties"]["timestamp"]
        assert set(ts["properties"]) == {"sec", "nsec"} and ts["properties"]["nsec"]["maximum"] == 999_999_999


def test_frame_transform_shape_and_rotation():
    ft = frame_transform(12.5, "world", "vehicle_truth", 3.0, -4.0, math.pi / 2, z=0.2).model_dump(mode="json")
    jsonschema.validate(ft, foxglove_schema("foxglove.FrameTransform"))
    assert ft["timestamp"] == {"sec": 12, "nsec": 500_000_000}
    assert ft["translation"] == {"x": 3.0, "y": -4.0, "z": 0.2}
    q = ft["rotation"]
    assert (q["x"], q["y"]) == (0.0, 0.0) and q["z"] == pytest.approx(math.sqrt(0.5)) and q["w"] == pytest.approx(math.sqrt(0.5))
    # a rotation by yaw about +z: the quaternion's yaw comes back
    for yaw in (-3.0, -1.0, 0.0, 0.7, 3.1):
        q = yaw_quaternion(yaw)
        assert 2 * math.atan2(q.z, q.w) == pytest.approx(yaw)


def test_scene_update_entities_have_every_primitive_list():
    geo = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [4, 0], [4, 2], [0, 2], [0, 0]]]},
         "properties": {"id": "walk", "kind": "sidewalk"}},
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": [1, 1]}, "properties": {"id": "t", "kind": "tree", "radius": 0.5}},
        {"type": "Feature", "geometry": {"type": "LineString", "coordinates": [[0, 0], [1, 1]]}, "properties": {"kind": "edge"}},
    ]}
    su = map_scene(geo, 1.0).model_dump(mode="json")
    jsonschema.validate(su, foxglove_schema("foxglove.SceneUpdate"))
    assert len(su["entities"]) == 3
    for e in su["entities"]:
        assert set(e) == SCENE_ENTITY_FIELDS and e["frame_id"] == "world"
    walk = next(e for e in su["entities"] if e["id"] == "walk")
    (ln,) = walk["lines"]
    assert set(ln) == LINE_FIELDS and ln["type"] == 1  # a polygon is a LINE_LOOP
    assert [(p["x"], p["y"]) for p in ln["points"]] == [(0, 0), (4, 0), (4, 2), (0, 2)]
    assert all(0.0 <= ln["color"][c] <= 1.0 for c in "rgba")


def _token(ttype: str, attrs, *, frame="world", stamp=5.0, version=1) -> dict:
    return {"id": "t1", "type": ttype, "version": version, "stamp": stamp, "source": "test", "frame": frame,
            "geometry": None, "attrs": attrs.model_dump(mode="json")}


def _tokens() -> list[dict]:
    ring = ((0.0, 0.0), (2.0, 0.0), (2.0, 4.0), (0.0, 4.0))
    line = ((1.0, 0.0), (1.0, 4.0))
    res = PerceptionResult(unit_id="u1", segment_id="s1", status="perceived", captured_at=4.0, sensor="colour",
                           frame="vehicle", view_frame=((0.0, 0.0), (8.0, -3.0), (8.0, 3.0)), navigable_region=ring)
    return [
        _token("route_plan", RoutePlan(plan_id="p", mission_id="m", step_index=0, node_ids=("a", "b"), edge_ids=("e",),
                                       segment_count=1, length_m=4.0, cost=4.0, polyline=line, start_xy=line[0], goal_xy=line[1])),
        _token("route_segment", RouteSegmentDescription(segment_id="s1", plan_id="p", segment_index=0, mode="follow-road",
                                                        path_object_ids=("w",), centreline=line, width_m=2.0, length_m=4.0,
                                                        exit=ExitCondition(point=line[1], gate=((0.0, 4.0), (2.0, 4.0)), heading=1.57))),
        _token("driving_unit", DrivingUnitDescription(unit_id="u1", segment_id="s1", unit_index=0, mode="follow-road",
                                                      region=ring, centreline=line, status="perceived")),
        _token("perception_result", res),
        _token("local_path_plan", LocalPathPlan(seq=3, segment_id="s1", poses=(PlanPose(x=0, y=0, yaw=0, speed=1),
                                                                             PlanPose(x=1, y=0, yaw=0, speed=1))), frame="local"),
        _token("mission_status", MissionStatus(mission_id="m", name="x", state="running", step_count=1)),
    ]


def test_token_events_validate_against_their_type_schema_and_imply_scene_updates():
    from modules.vocabulary import TOKEN_TYPES

    models = {n: m for m, n in TOKEN_TYPES.items()}
    scene = foxglove_schema("foxglove.SceneUpdate")
    derived_topics = set()
    for tok in _tokens():
        schema = token_schema(tok["type"], models[tok["type"]])
        assert not _refs(schema)
        jsonschema.validate({"event": "new", "token": tok}, schema)
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate({"event": "new", "token": {**tok, "version": 0}}, schema)
        for d in derive_token("new", tok, 6.0):
            jsonschema.validate(d.message.model_dump(mode="json"), scene)
            derived_topics.add(d.topic)
    assert {"/scene/route", "/scene/segment", "/scene/driving_units", "/scene/perception", "/scene/local_path"} <= derived_topics
    # a result stated in the vehicle frame at capture time is drawn in that frame at that time
    (p,) = derive_token("new", _tokens()[3], 6.0)
    ent = p.message.entities[0]
    assert ent.frame_id == "vehicle" and ent.timestamp.sec == 4
    # cancelled units and deleted tokens become deletions
    (d,) = derive_token("deleted", _tokens()[2], 7.0)
    assert d.message.deletions[0].id == "u1" and not d.message.entities


def test_channel_families_schemas_validate_what_is_published():
    samples = {
        "sim/clock": encode(SimClock(stamp=1.5, rtf=20.0, rtf_actual=19.0, step=150)),
        "sim/truth": encode(TruthPose(stamp=1.5, x=1, y=2, z=0, yaw=0.1, v=0.5, omega=0, curvature=0)),
        "heartbeat/pilot": encode_heartbeat(Heartbeat(module="pilot", seq=3, wall_time=1.0, period_s=1.0, pid=1)),
        "sim/preview": encode_preview(SimPreview(stamp=2.0, camera=PreviewImage(format="jpeg", width=2, height=2, source_width=4,
                                                                                 source_height=4, data=b"\xff\xd8\x00"))),
        "mission/events": json.dumps(MissionStatus(mission_id="m", name="x", state="queued", step_count=1).model_dump(mode="json")).encode(),
    }
    for rel, payload in samples.items():
        fam = family_of(rel)
        assert fam.model is not None, rel
        value = decode_payload(payload, rel == "mission/events")
        doc = json.loads(to_json_bytes(value))
        jsonschema.validate(doc, fam.schema())
        assert topic_of(rel) == "/" + rel
    # the preview's bytes are base64 text, as the schema says
    s = family_of("sim/preview").schema()
    data = s["properties"]["camera"]["anyOf"][0]["properties"]["data"]
    assert data == {"contentEncoding": "base64", "title": "Data", "type": "string"}
    assert family_of("bb/write/pilot-1").schema_name == "sidewalk.bb.WriteBatch"
    assert family_of("something/else").schema_name == "sidewalk.Raw"


def test_derived_poses_from_truth_and_the_blackboard_write_channel():
    (t,) = derive_sample("sim/truth", {"stamp": 3.0, "x": 1.0, "y": 2.0, "z": 0.1, "yaw": 0.5}, 3.0)
    assert t.topic == "/tf/truth" and t.message.child_frame_id == "vehicle_truth" and t.message.parent_frame_id == "world"
    batch = msgpack.unpackb(msgpack.packb([7, [
        {"op": "pose", "parent": "local", "child": "vehicle", "pose": [1.0, 0.0, 0.2], "stamp": 4.0, "hold": 0.5},
        {"op": "post", "type": "x", "attrs": {}},
        {"op": "pose", "parent": "world", "child": "local", "pose": [10.0, 5.0, 0.0], "stamp": 4.1, "hold": None},
        {"op": "static", "parent": "vehicle", "child": "camera", "pose": [1.0, 0.0, 0.0]},
    ]]))
    out = derive_sample("bb/write/helm-1", batch, 4.2)
    assert [(d.topic, d.message.parent_frame_id, d.message.child_frame_id) for d in out] == [
        ("/tf", "local", "vehicle"), ("/tf", "world", "local"), ("/tf_static", "vehicle", "camera")]
    assert out[0].stamp == 4.0 and out[1].stamp == 4.1
    eddie = derive_sample("eddie/pub/controller/state", {"stamp": 2.0, "x": 1, "y": 0, "yaw": 0, "v": 1.0, "extra": "ignored"}, 2.0)
    assert eddie[0].message.parent_frame_id == "local" and eddie[0].message.child_frame_id == "vehicle"


def test_json_conversion_of_awkward_values():
    assert json.loads(to_json_bytes([1, 2])) == {"payload": [1, 2]}
    assert json.loads(to_json_bytes({"a": float("nan"), "b": b"\x00\x01", "c": (1.0, float("inf"))})) == {
        "a": None, "b": "AAE=", "c": [1.0, None]}
    assert jsonable({1: b"x"}) == {"1": "eA=="}


def test_sink_keeps_each_channel_in_order_and_the_reader_reads_it_back(tmp_path):
    path = tmp_path / "r.mcap"
    sink = McapSink(path)
    a = sink.channel("/a", "sidewalk.Raw", {"type": "object"})
    b = sink.channel("/b", "sidewalk.Raw", {"type": "object"})
    assert sink.channel("/a", "sidewalk.Raw", None) == a
    sink.write(a, "/a", 2.0, {"i": 0}, publish_s=2.0)
    sink.write(a, "/a", 1.0, {"i": 1}, publish_s=0.5)  # received late with an old stamp: logged in order
    sink.write(b, "/b", 0.5, {"i": 2})
    sink.close()
    rec = open_recording(path)
    ch = rec.channels()
    assert {t: c.count for t, c in ch.items()} == {"/a": 2, "/b": 1}
    msgs = list(rec.messages())
    assert [(m.topic, m.log_time, m.value["i"]) for m in msgs] == [("/b", 0.5, 2), ("/a", 2.0, 0), ("/a", 2.0, 1)]
    assert msgs[2].publish_time == 0.5
    assert rec.time_range() == (0.5, 2.0)


def test_bad_recordings_say_so_in_one_line(tmp_path):
    with pytest.raises(RecordingError, match="no recording at"):
        open_recording(tmp_path / "missing.mcap")
    (tmp_path / "text.mcap").write_text("hello")
    with pytest.raises(RecordingError, match="not an MCAP file"):
        open_recording(tmp_path / "text.mcap")
    with pytest.raises(RecordingError, match="not a file"):
        open_recording(tmp_path)


def test_map_and_annotations_as_geojson_in_wgs84():
    from sidewalk.recording.derive import annotation_points
    from sidewalk.recording.geo_anchor import GEO_ORIGIN, annotations_geojson, lonlat, map_geojson

    lon0, lat0 = lonlat(0.0, 0.0)
    assert (lat0, lon0) == pytest.approx(GEO_ORIGIN)
    # 111.3 km per degree of latitude; a degree of longitude is shorter by cos(latitude)
    lon, lat = lonlat(100.0, 1000.0)
    assert (lat - lat0) * 111_195 == pytest.approx(1000.0, rel=2e-3)
    assert (lon - lon0) * 111_195 * math.cos(math.radians(lat0)) == pytest.approx(100.0, rel=2e-3)
    fc = json.loads(map_geojson({"features": [
        {"geometry": {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 10], [0, 0]]]}, "properties": {"id": "b", "kind": "building", "colour": {"x": 1}}},
        {"geometry": None}]}).geojson)
    (f,) = fc["features"]
    assert f["properties"] == {"id": "b", "kind": "building"} and f["geometry"]["coordinates"][0][1] == lonlat(10, 0)
    anns = [{"id": "r0", "type": "route", "kind": "line", "points": [[0, 0], [0, 20]], "destination": "vision"},
            {"id": "z", "type": "stop_at_object", "kind": "polygon", "points": [[0, 0], [1, 0], [1, 1]]},
            {"id": "p", "type": "mark", "kind": "point", "points": [[3, 4]]}, {"id": "empty", "type": "x"}]
    kinds = {g["properties"]["id"]: g["geometry"]["type"] for g in json.loads(annotations_geojson(anns, annotation_points).geojson)["features"]}
    assert kinds == {"r0": "LineString", "z": "Polygon", "p": "Point"}
