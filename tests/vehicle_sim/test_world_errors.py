"""Invalid world files are rejected with errors naming the file, the feature and what is wrong."""

from __future__ import annotations

import copy
import json

import pytest

from vehicle_sim.worldfile import WorldFileError, load_world, parse_world


def _sidewalk(fid="sw1", **over):
    f = {
        "type": "Feature",
        "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [10, 0], [10, 2], [0, 2], [0, 0]]]},
        "properties": {"id": fid, "kind": "sidewalk", "role": "path", "cost": 1.0,
                       "colour": {"type": "GRAY", "nominal": [150, 150, 150]},
                       "appearance": {"mean": [146, 144, 140], "std": [8, 8, 8]}, "shape": {"type": "flat", "z": 0.0}},
    }
    f["properties"].update(over)
    return f


def _node(fid, x, y, **over):
    p = {"id": fid, "kind": "node", "node_kind": "place", "name": fid}
    p.update(over)
    return {"type": "Feature", "geometry": {"type": "Point", "coordinates": [x, y]}, "properties": p}


def _edge(fid="e1", frm="a", to="b", coords=((0, 1), (10, 1)), **over):
    p = {"id": fid, "kind": "edge", "from": frm, "to": to, "mode": "follow-road", "path_objects": ["sw1"], "width": 2.0}
    p.update(over)
    return {"type": "Feature", "geometry": {"type": "LineString", "coordinates": [list(c) for c in coords]}, "properties": p}


def _good() -> dict:
    return {"type": "FeatureCollection", "name": "tiny", "start": {"x": 0, "y": 1, "yaw_deg": 0, "node": "a"},
            "features": [_sidewalk(), _node("a", 0, 1), _node("b", 10, 1), _edge()]}


def _write(tmp_path, data) -> str:
    p = tmp_path / "bad.world.geojson"
    p.write_text(data if isinstance(data, str) else json.dumps(data))
    return str(p)


def _problems(tmp_path, data) -> tuple[str, WorldFileError]:
    path = _write(tmp_path, data)
    with pytest.raises(WorldFileError) as ei:
        load_world(path)
    return path, ei.value


def test_the_good_file_loads(tmp_path):
    w = load_world(_write(tmp_path, _good()))
    assert w.name == "tiny" and len(w.objects) == 1 and len(w.edges) == 1


def test_invalid_json_names_line_and_column(tmp_path):
    path, err = _problems(tmp_path, '{"type": "FeatureCollection",\n "features": [,]}')
    assert path in str(err) and "line 2" in str(err) and "column" in str(err)


def test_not_a_feature_collection(tmp_path):
    _, err = _problems(tmp_path, {"type": "Feature"})
    assert "FeatureCollection" in str(err)


@pytest.mark.parametrize(
    "mutate, field, words",
    [
        (lambda d: d["features"][0]["properties"].update(kind="sidwalk"), "properties.kind", "unknown kind 'sidwalk'"),
        (lambda d: d["features"][0]["properties"].pop("colour"), "properties.colour", "required field is missing"),
        (lambda d: d["features"][0]["properties"]["colour"].update(nominal=[300, 0, 0]), "properties.colour.nominal", "0..255"),
        (lambda d: d["features"][0]["properties"]["colour"].update(type="GREY"), "properties.colour.type", "'GRAY'"),
        (lambda d: d["features"][0]["properties"].update(colour={"mean": [150, 150, 150], "std": [8, 8, 8]}),
         "properties.colour", 'belong in "appearance"'),
        (lambda d: d["features"][0]["properties"]["appearance"].update(mean=[300, 0, 0]), "properties.appearance.mean", "0..255"),
        (lambda d: d["features"][0]["properties"]["appearance"].update(reflectance=2.0), "properties.appearance.reflectance", "1"),
        (lambda d: d["features"][0]["properties"].update(reflectance=0.5), "properties.reflectance", "unknown field"),
        (lambda d: d["features"][0]["properties"].update(color={"mean": [1, 2, 3]}), "properties.color", "unknown field"),
        (lambda d: d["features"][0]["properties"].update(role="road"), "properties.role", "path"),
        (lambda d: d["features"][0]["properties"].update(cost=-1.0), "properties.cost", ">= 0"),
        (lambda d: d["features"][0]["properties"].pop("cost"), "properties.cost", "finite cost"),
        (lambda d: d["features"][0]["properties"].update(shape={"type": "tree", "trunk_radius": 0.2, "crown_radius": 2, "height": 6, "crown_base": 2}),
         "properties.shape.type", "cannot have shape 'tree'"),
        (lambda d: d["features"][0]["properties"].update(shape={"type": "stairs", "rise": 1.0, "axis_deg": 90, "step_rise": 0.2}),
         "properties.shape.type", "cannot have shape 'stairs'"),
        (lambda d: d["features"][0]["geometry"].update(coordinates=[[[0, 0], [10, 10], [10, 0], [0, 10], [0, 0]]]),
         "geometry.coordinates", "invalid polygon"),
        (lambda d: d["features"][0]["geometry"].update(coordinates=[[[0, 0], [10, 0], [10, 2], [0, 2]]]),
         "geometry.coordinates", "closed"),
        (lambda d: d["features"][0]["geometry"].update(type="LineString"), "geometry.type", "Polygon or a Point"),
        (lambda d: d["features"][3]["properties"].update(to="nowhere"), "properties.to", "unknown node 'nowhere'"),
        (lambda d: d["features"][3]["properties"].update(mode="fly"), "properties.mode", "follow-road"),
        (lambda d: d["features"][3]["properties"].update(path_objects=["ghost"]), "properties.path_objects", "unknown object 'ghost'"),
        (lambda d: d["features"][3]["geometry"].update(coordinates=[[0, 1], [20, 1]]), "geometry.coordinates", "from node 'b'"),
        (lambda d: d["features"][2]["properties"].pop("name"), "properties.name", "needs a name"),
        (lambda d: d["features"][2]["properties"].update(node_kind="junction"), "properties.node_kind", "intersection"),
    ],
)
def test_bad_feature_is_named(tmp_path, mutate, field, words):
    data = _good()
    mutate(data)
    path, err = _problems(tmp_path, data)
    text = str(err)
    assert path in text
    assert any(p.field == field for p in err.problems), [str(p) for p in err.problems]
    assert words in text, text
    # the message names the feature by id
    assert "id '" in text


def test_point_objects_need_a_radius(tmp_path):
    data = _good()
    data["features"].append({"type": "Feature", "geometry": {"type": "Point", "coordinates": [5, 5]},
                             "properties": {"id": "mb", "kind": "mailbox", "role": "landmark",
                                            "colour": {"type": "BLUE", "nominal": [0, 0, 200]}, "shape": {"type": "post", "height": 1.1}}})
    _, err = _problems(tmp_path, data)
    (p,) = err.problems
    assert p.index == 4 and p.feature_id == "mb" and p.field == "properties.radius"


def test_duplicate_ids_and_all_problems_reported_together(tmp_path):
    data = _good()
    data["features"].append(copy.deepcopy(data["features"][0]))
    data["features"][1]["properties"]["kind"] = "bogus"
    data["start"]["node"] = "zz"
    _, err = _problems(tmp_path, data)
    text = str(err)
    assert "duplicate id" in text and "feature #4" in text
    assert "unknown kind 'bogus'" in text
    assert len(err.problems) >= 2


def test_unknown_start_node(tmp_path):
    data = _good()
    data["start"]["node"] = "zz"
    _, err = _problems(tmp_path, data)
    assert any(p.field == "start.node" for p in err.problems)


def test_feature_without_id(tmp_path):
    data = _good()
    del data["features"][1]["properties"]["id"]
    _, err = _problems(tmp_path, data)
    assert err.problems[0].index == 1 and "properties.id" in str(err)


def test_missing_file_and_unknown_name():
    with pytest.raises(FileNotFoundError, match="known"):
        load_world("atlantis")


def test_parse_world_source_is_named():
    with pytest.raises(WorldFileError, match="^inline: "):
        parse_world("[]", source="inline")


def test_reference_problems_come_with_feature_problems_and_indices(tmp_path):
    data = _good()
    data["features"][0]["properties"]["appearance"]["std"] = [-1, 0, 0]  # the sidewalk is broken …
    data["features"][3]["properties"]["to"] = "nowhere"  # … and the edge points at nothing
    _, err = _problems(tmp_path, data)
    fields = {(p.index, p.field) for p in err.problems}
    assert (0, "properties.appearance.std") in fields and (3, "properties.to") in fields
    # the edge's reference to the broken sidewalk is not reported as "unknown object"
    assert "unknown object 'sw1'" not in str(err)
