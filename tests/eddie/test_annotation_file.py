"""Annotated map files: GeoJSON round trip; a bad file gets an error naming file, feature and field."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from eddie.annotated_map import (Annotation, AnnotationFileError, Location, load_annotations, save_annotations)


def _anns() -> list[Annotation]:
    return [
        Annotation(id="p", type="stop_at_object", destination="obstacles", trigger="cross", reach=1.0,
                   location=Location.point(1.5, -2.0), data=b"\x00\x01\xffbytes", text="the mailbox"),
        Annotation(id="l", type="set_speed", destination="controller", trigger="cross",
                   location=Location.line([(0, 0), (0, 3), (1, 4)]), next_id="g", refire=True),
        Annotation(id="g", type="intersection", destination="vision", trigger="enter", previous_id="l",
                   location=Location.polygon([(0, 0), (2, 0), (2, 2), (0, 2)]), used=True),
    ]


def test_round_trip_is_plain_geojson(tmp_path: Path) -> None:
    f = tmp_path / "m.annotated.geojson"
    save_annotations(f, _anns(), name="test")
    doc = json.loads(f.read_text())
    assert doc["type"] == "FeatureCollection" and "crs" not in doc
    kinds = [ft["geometry"]["type"] for ft in doc["features"]]
    assert kinds == ["Point", "LineString", "Polygon"]
    ring = doc["features"][2]["geometry"]["coordinates"][0]
    assert ring[0] == ring[-1]  # RFC 7946: closed rings
    assert doc["features"][0]["properties"]["data_size"] == 8
    assert load_annotations(f) == _anns()


def _write(tmp_path: Path, doc) -> Path:
    f = tmp_path / "bad.geojson"
    f.write_text(json.dumps(doc) if not isinstance(doc, str) else doc)
    return f


def _good_doc(tmp_path: Path) -> dict:
    f = tmp_path / "good.geojson"
    save_annotations(f, _anns())
    return json.loads(f.read_text())


@pytest.mark.parametrize("mutate, feature, fid, field", [
    (lambda d: d["features"][1]["properties"].update(data_base64="@@not base64"), 1, "l", "properties.data_base64"),
    (lambda d: d["features"][0]["properties"].update(data_size=3), 0, "p", "properties.data_size"),
    (lambda d: d["features"][1]["geometry"].update(type="MultiPoint"), 1, "l", "geometry.type"),
    (lambda d: d["features"][1]["geometry"].update(coordinates=[[0, 0]]), 1, "l", "geometry.coordinates"),
    (lambda d: d["features"][0]["geometry"].update(coordinates=["x", 1]), 0, "p", "geometry.coordinates"),
    (lambda d: d["features"][2]["properties"].update(trigger="sometimes"), 2, "g", "properties.trigger"),
    (lambda d: d["features"][2]["properties"].update(id="p"), 2, "p", "properties.id"),
    (lambda d: d["features"][0]["properties"].update(reach=-1), 0, "p", "properties.reach"),
    (lambda d: d["features"][1]["properties"].pop("type"), 1, "l", "properties.type"),
])
def test_bad_feature_names_file_feature_and_field(tmp_path: Path, mutate, feature, fid, field) -> None:
    doc = _good_doc(tmp_path)
    mutate(doc)
    f = _write(tmp_path, doc)
    with pytest.raises(AnnotationFileError) as e:
        load_annotations(f)
    err = e.value
    assert (err.path, err.feature, err.feature_id, err.field) == (str(f), feature, fid, field)
    msg = str(err)
    assert str(f) in msg and f"feature {feature}" in msg and field in msg and "\n" not in msg


def test_bad_file_level_errors_name_the_file(tmp_path: Path) -> None:
    for doc, field in (("{not json", ""), ({"type": "Feature"}, "type"), ({"type": "FeatureCollection"}, "features")):
        f = _write(tmp_path, doc)
        with pytest.raises(AnnotationFileError) as e:
            load_annotations(f)
        assert e.value.path == str(f) and e.value.field == field and str(f) in str(e.value)
    with pytest.raises(AnnotationFileError, match="cannot read"):
        load_annotations(tmp_path / "missing.geojson")
