"""Spec semantics evaluated on the pure core (no network): every predicate, frames, any_of, newest, limit."""

from __future__ import annotations

import math

import pytest

from blackboard import (
    AttrPredicate,
    BadSpecError,
    Intersects,
    Near,
    Nearest,
    Point,
    Polygon,
    Polyline,
    Spec,
    Within,
)
from blackboard.ops import RetrieveRequest
from tests.blackboard.conftest import op, post, pt, square


def ids(core, spec, **kw):
    return [t["id"] for t in core.retrieve(RetrieveRequest(spec=spec, **kw))]


@pytest.fixture
def filled(core):
    toks = {}
    toks["oak"] = post(core, "bbt_landmark", {"name": "oak", "kind": "tree", "height": 8.0, "tags": ["big"], "info": {"age": 80}}, stamp=1.0, geometry=pt(1, 1))
    toks["box"] = post(core, "bbt_landmark", {"name": "box", "kind": "mailbox", "height": 1.2}, stamp=2.0, geometry=pt(5, 5))
    toks["lamp"] = post(core, "bbt_landmark", {"name": "lamp", "kind": "lamp", "height": 4.0, "info": {"age": 3}}, stamp=3.0, geometry=pt(20, 0))
    toks["seg0"] = post(core, "bbt_segment", {"index": 0}, stamp=1.5, geometry={"kind": "polyline", "points": [[0, 0], [10, 0]]})
    toks["seg1"] = post(core, "bbt_segment", {"index": 1, "mode": "turn"}, stamp=2.5, geometry={"kind": "polyline", "points": [[10, 0], [10, 10]]})
    toks["area"] = post(core, "bbt_obstacle", {"confidence": 0.9}, stamp=4.0, geometry=square(2, 2, 4, 4))
    toks["nogeo"] = post(core, "bbt_segment", {"index": 2}, stamp=0.5)
    return {k: v["id"] for k, v in toks.items()}


@pytest.mark.parametrize(
    "op_, value, expected",
    [
        ("==", "tree", ["oak"]),
        ("!=", "tree", ["box", "lamp"]),
        ("in", ["lamp", "mailbox"], ["box", "lamp"]),
    ],
)
def test_equality_and_membership(core, filled, op_, value, expected):
    spec = Spec(type="bbt_landmark", where=[AttrPredicate(path="kind", op=op_, value=value)])
    assert ids(core, spec) == [filled[k] for k in expected]


@pytest.mark.parametrize(
    "op_, value, expected",
    [("<", 4.0, ["box"]), ("<=", 4.0, ["box", "lamp"]), (">", 4.0, ["oak"]), (">=", 4.0, ["oak", "lamp"])],
)
def test_ordering_predicates(core, filled, op_, value, expected):
    spec = Spec(type="bbt_landmark", where=[AttrPredicate(path="height", op=op_, value=value)])
    assert ids(core, spec) == [filled[k] for k in expected]


def test_dotted_paths_exists_and_incomparable_values(core, filled):
    assert ids(core, Spec(where=[AttrPredicate(path="info.age", op=">", value=10)])) == [filled["oak"]]
    assert ids(core, Spec(type="bbt_landmark", where=[AttrPredicate(path="info.age", op="exists")])) == [filled["oak"], filled["lamp"]]
    assert ids(core, Spec(type="bbt_landmark", where=[AttrPredicate(path="info.age", op="exists", value=False)])) == [filled["box"]]
    assert ids(core, Spec(where=[AttrPredicate(path="tags.0", op="==", value="big")])) == [filled["oak"]]
    # comparing a string with a number never matches (and is no error)
    assert ids(core, Spec(type="bbt_landmark", where=[AttrPredicate(path="name", op="<", value=3)])) == []
    # several predicates are ANDed
    spec = Spec(type="bbt_landmark", where=[AttrPredicate(path="height", op=">", value=2), AttrPredicate(path="kind", op="!=", value="tree")])
    assert ids(core, spec) == [filled["lamp"]]


def test_type_filter_and_no_type(core, filled):
    assert ids(core, Spec(type="bbt_segment")) == [filled["seg0"], filled["seg1"], filled["nogeo"]]
    assert len(ids(core, Spec())) == 7
    assert ids(core, Spec(type="nothing-of-this-type")) == []


def test_within_intersects_near(core, filled):
    box = Polygon(points=[(0, 0), (6, 0), (6, 6), (0, 6)])
    assert ids(core, Spec(geometry=Within(box))) == [filled["oak"], filled["box"], filled["area"]]
    # a polyline on the boundary is covered; one leaving it is not
    assert filled["seg0"] not in ids(core, Spec(geometry=Within(box)))
    assert ids(core, Spec(geometry=Intersects(Polyline(points=[(3, -1), (3, 10)])))) == [filled["seg0"], filled["area"]]
    assert ids(core, Spec(type="bbt_landmark", geometry=Near(Point(x=20, y=3), 3.0))) == [filled["lamp"]]
    assert ids(core, Spec(type="bbt_landmark", geometry=Near(Point(x=20, y=3), 2.9))) == []


def test_nearest_k_in_distance_order(core, filled):
    got = ids(core, Spec(type="bbt_landmark", geometry=Nearest(Point(x=6, y=6), 2)))
    assert got == [filled["box"], filled["oak"]]
    assert ids(core, Spec(type="bbt_landmark", geometry=Nearest(Point(x=1000, y=0), 1))) == [filled["lamp"]]


def test_any_of_is_or_and_combines_with_outer_filters(core, filled):
    spec = Spec(any_of=[Spec(type="bbt_obstacle"), Spec(type="bbt_landmark", where=[AttrPredicate(path="kind", op="==", value="lamp")])])
    assert ids(core, spec) == [filled["lamp"], filled["area"]]
    spec = Spec(geometry=Within(Polygon(points=[(0, 0), (6, 0), (6, 6), (0, 6)])), any_of=[Spec(type="bbt_obstacle"), Spec(type="bbt_segment")])
    assert ids(core, spec) == [filled["area"]]


def test_newest_and_limit(core, filled):
    assert ids(core, Spec(type="bbt_landmark", newest=True)) == [filled["lamp"]]
    assert ids(core, Spec(type="bbt_landmark", limit=2)) == [filled["oak"], filled["box"]]
    assert ids(core, Spec(where=[AttrPredicate(path="height", op="<", value=5)], newest=True)) == [filled["lamp"]]


def test_predicates_stated_in_other_frames(core, filled):
    # local frame is world shifted by (100, 0): the world point (1,1) is local (-99, 1)
    op(core, {"op": "pose", "parent": "world", "child": "local", "pose": [100.0, 0.0, 0.0], "stamp": 0.0, "hold": None})
    local_box = Polygon(points=[(-100, 0), (-98, 0), (-98, 2), (-100, 2)])
    assert ids(core, Spec(type="bbt_landmark", geometry=Within(local_box, frame="local"))) == [filled["oak"]]
    # a static sensor frame on a moving vehicle: tokens seen by the camera at their own stamps
    op(core, {"op": "static", "parent": "vehicle", "child": "camera", "pose": [1.0, 0.0, 0.0]})
    for t, x in ((0.0, -100.0), (10.0, -90.0)):
        op(core, {"op": "pose", "parent": "local", "child": "vehicle", "pose": [x, 0.0, math.pi / 2], "stamp": t})
    # obstacle 2 m straight ahead of the camera at t=5: vehicle at local (-95,0) heading +y → camera at (-95, 1)
    seen = post(core, "bbt_obstacle", {"confidence": 0.5}, stamp=5.0, frame="camera", geometry=pt(2, 0))
    # in world: local (-95, 3) → world (5, 3)
    near = Spec(type="bbt_obstacle", geometry=Near(Point(x=5, y=3), 0.01))
    assert ids(core, near) == [seen["id"]]
    out = core.retrieve(RetrieveRequest(spec=near, frame="world"))
    assert out[0]["frame"] == "world"
    assert out[0]["geometry"]["x"] == pytest.approx(5.0) and out[0]["geometry"]["y"] == pytest.approx(3.0)
    # relative to the vehicle at t=10 (local (-90, 0), heading +y): 3 m ahead, 5 m to the left
    rel = Spec(type="bbt_obstacle", geometry=Near(Point(x=3, y=5), 0.01, frame="vehicle", stamp=10.0))
    got = core.retrieve(RetrieveRequest(spec=rel, frame="vehicle", frame_stamp=10.0))
    assert [t["id"] for t in got] == [seen["id"]]
    assert got[0]["geometry"]["x"] == pytest.approx(3.0) and got[0]["geometry"]["y"] == pytest.approx(5.0)


def test_tokens_outside_pose_history_do_not_match_geometric_predicates(core):
    op(core, {"op": "pose", "parent": "local", "child": "vehicle", "pose": [0.0, 0.0, 0.0], "stamp": 10.0})
    post(core, "bbt_obstacle", {"confidence": 0.5}, stamp=3.0, frame="vehicle", geometry=pt(1, 0))
    assert core.retrieve(Spec(geometry=Near(Point(x=0, y=0), 100.0, frame="local")).model_dump(mode="json")) == []
    assert len(core.retrieve(Spec(type="bbt_obstacle").model_dump(mode="json"))) == 1


@pytest.mark.parametrize(
    "bad",
    [
        [],
        "spec",
        {"type": 3},
        {"where": [{"path": "a", "op": "~", "value": 1}]},
        {"where": [{"path": "a", "op": "in", "value": 1}]},
        {"where": [{"path": "a..b", "op": "==", "value": 1}]},
        {"geometry": {"op": "within", "polygon": {"kind": "polygon", "points": [[0, 0], [1, 1], [0, 0]]}}},
        {"geometry": {"op": "near", "geometry": {"kind": "point", "x": 0, "y": 0}, "distance": -1}},
        {"geometry": {"op": "nearest", "point": {"kind": "point", "x": 0, "y": 0}, "k": 0}},
        {"geometry": {"op": "within", "polygon": {"kind": "polygon", "points": [[0, 0], [1, 1], [1, 0], [0, 1]]}}},
        {"limit": 0},
        {"newest": "yes please"},
        {"unknown": 1},
    ],
)
def test_bad_specs_raise_bad_spec_error(core, bad):
    with pytest.raises(BadSpecError):
        core.retrieve(bad)


def test_large_store_uses_the_rtree_and_returns_the_right_tokens(core):
    import numpy as np

    rng = np.random.default_rng(1)
    xy = rng.uniform(0, 1000, size=(5000, 2))
    ops = [{"op": "post", "type": "bbt_obstacle", "attrs": {"confidence": 0.5}, "stamp": float(i), "frame": "world",
            "geometry": pt(float(x), float(y))} for i, (x, y) in enumerate(xy)]
    core.apply_requests([ops])
    poly = Polygon(points=[(100, 100), (200, 100), (200, 180), (100, 180)])
    got = core.retrieve(Spec(geometry=Within(poly)).model_dump(mode="json"))
    inside = [(x, y) for x, y in xy if 100 <= x <= 200 and 100 <= y <= 180]
    assert len(got) == len(inside) > 0
    near = core.retrieve(Spec(geometry=Nearest(Point(x=500, y=500), 5)).model_dump(mode="json"))
    d = np.hypot(xy[:, 0] - 500, xy[:, 1] - 500)
    exp = np.sort(d)[:5]
    got_d = [math.hypot(t["geometry"]["x"] - 500, t["geometry"]["y"] - 500) for t in near]
    np.testing.assert_allclose(got_d, exp)


def test_within_returns_exactly_the_tokens_inside_in_id_order_whether_its_polygon_was_just_validated_or_not(core):
    """A Within region reuses the shapely polygon its validation built (blackboard.geometry.polygon_shape):
    points from the grid and lines and polygons from the R*Tree, in two frames, against a brute-force test."""
    import numpy as np
    import shapely

    from blackboard.geometry import _SHAPES_KEPT

    rng = np.random.default_rng(5)
    ops, shapes = [], []
    for i in range(3000):
        x, y = (float(v) for v in rng.uniform(0, 200, size=2))
        frame = "world" if i % 3 else "site"  # site: world shifted by (50, 0), a static frame
        r = i % 7
        if r == 0:
            g = {"kind": "polyline", "points": [[x, y], [x + 3.0, y + 1.0]]}
            s = shapely.LineString([(x, y), (x + 3.0, y + 1.0)])
        elif r == 1:
            g = square(x, y, x + 2.0, y + 2.0)
            s = shapely.box(x, y, x + 2.0, y + 2.0)
        else:
            g, s = pt(x, y), shapely.Point(x, y)
        ops.append({"op": "post", "type": "bbt_obstacle", "attrs": {"confidence": 0.5}, "stamp": 0.0, "frame": frame, "geometry": g})
        shapes.append(shapely.affinity.translate(s, 50.0, 0.0) if frame == "site" else s)
    core.apply_requests([[{"op": "static", "parent": "world", "child": "site", "pose": [50.0, 0.0, 0.0]}]])
    results, _ = core.apply_requests([ops])
    ids = [r["ok"]["id"] for r in results[0]]
    found = 0
    for k in range(30):
        cx, cy = (float(v) for v in rng.uniform(20, 230, size=2))
        n = int(rng.integers(3, 9))
        ang = np.sort(rng.uniform(0, 2 * np.pi, size=n))
        rad = rng.uniform(5, 30, size=n)  # a star-shaped, often concave polygon
        pts = [(cx + r * np.cos(a), cy + r * np.sin(a)) for a, r in zip(ang, rad)]
        if k % 2:
            pts.append(pts[0])  # closed ring: the repeated vertex is dropped by validation, not by the wire
        poly = Polygon(points=pts)
        spec = Spec(type="bbt_obstacle", geometry=Within(poly, frame="world"))
        if k % 3 == 0:
            for _ in range(_SHAPES_KEPT + 1):  # validate others until this polygon's shape is forgotten
                Polygon(points=[(0, 0), (1, 0), (0, 1)])
        want_shape = shapely.Polygon(pts)
        want = [ids[i] for i, s in enumerate(shapes) if want_shape.covers(s)]
        got = [t["id"] for t in core.retrieve(spec)]
        assert got == want, (k, len(got), len(want))
        assert got == [t["id"] for t in core.retrieve(spec)]  # asked again: the same
        found += len(got)
    assert found > 300  # the regions held something to find
