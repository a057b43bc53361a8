"""Store and core without network: CAS, persistence on reopen, typed validation errors, monitor matching."""

from __future__ import annotations

import pytest

from blackboard import (
    AttrPredicate,
    BadRequestError,
    InvalidTokenError,
    NotFoundError,
    Spec,
    UnknownTypeError,
    VersionConflictError,
    Within,
    Polygon,
)
from blackboard.core import BlackboardCore
from blackboard.store import Store
from tests.blackboard.conftest import op, post, pt, square


def test_update_is_compare_and_set(core):
    t = post(core, "bbt_segment", {"index": 1}, stamp=1.0)
    t2 = op(core, {"op": "update", "id": t["id"], "expected_version": 1, "attrs": {"index": 2}})
    assert t2["version"] == 2 and t2["attrs"]["index"] == 2 and t2["stamp"] == 1.0
    with pytest.raises(VersionConflictError):
        op(core, {"op": "update", "id": t["id"], "expected_version": 1, "attrs": {"index": 3}})
    # two writers racing in one commit: the second one loses
    (res,), _ = core.apply_requests([[
        {"op": "update", "id": t["id"], "expected_version": 2, "attrs": {"index": 4}},
        {"op": "update", "id": t["id"], "expected_version": 2, "attrs": {"index": 5}},
    ]])
    assert res[0]["ok"]["version"] == 3 and res[1]["error"] == "version_conflict"
    with pytest.raises(BadRequestError):
        op(core, {"op": "update", "id": t["id"], "attrs": {"index": 3}})
    with pytest.raises(NotFoundError):
        op(core, {"op": "update", "id": "t999", "expected_version": 1})
    with pytest.raises(VersionConflictError):
        op(core, {"op": "delete", "id": t["id"], "expected_version": 1})
    op(core, {"op": "delete", "id": t["id"], "expected_version": 3})
    with pytest.raises(NotFoundError):
        op(core, {"op": "delete", "id": t["id"]})


def test_update_changes_geometry_stamp_and_frame_and_reindexes(core):
    t = post(core, "bbt_landmark", {"name": "a"}, geometry=pt(0, 0))
    op(core, {"op": "update", "id": t["id"], "expected_version": 1, "geometry": pt(50, 50), "stamp": 9.0})
    spec = Spec(geometry=Within(Polygon(points=[(40, 40), (60, 40), (60, 60)]))).model_dump(mode="json")
    (got,) = core.retrieve(spec)
    assert got["version"] == 2 and got["stamp"] == 9.0
    assert core.retrieve(Spec(geometry=Within(Polygon(points=[(-1, -1), (1, -1), (1, 1)]))).model_dump(mode="json")) == []


@pytest.mark.parametrize(
    "bad, err",
    [
        ({"type": "nope", "attrs": {}}, UnknownTypeError),
        ({"type": 5, "attrs": {}}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": "many"}}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1, "extra": 1}}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": [1]}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "stamp": float("nan")}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "stamp": "now"}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "frame": "a/b"}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "geometry": {"kind": "circle"}}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "geometry": {"kind": "point", "x": 1}}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "geometry": {"kind": "polygon", "points": [[0, 0], [1, 1], [1, 0], [0, 1]]}}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "geometry": {"kind": "polyline", "points": [[0, 0]]}}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "geometry": {"kind": "point", "x": float("inf"), "y": 0}}, InvalidTokenError),
        ({"type": "bbt_segment", "attrs": {"index": 1}, "bogus": True}, InvalidTokenError),
    ],
)
def test_invalid_posts_get_typed_errors_and_store_nothing(core, bad, err):
    with pytest.raises(err):
        op(core, {"op": "post", "stamp": 0.0, **bad})
    assert len(core.store) == 0


def test_bad_ops_do_not_spoil_good_ones_in_the_same_commit(core):
    (res,), changes = core.apply_requests([[
        {"op": "post", "type": "bbt_segment", "attrs": {"index": 1}, "stamp": 0.0},
        {"op": "explode"},
        "garbage",
        {"op": "pose", "parent": "local", "child": "vehicle", "pose": [0, 0], "stamp": 0.0},
        {"op": "post", "type": "bbt_segment", "attrs": {"index": 2}, "stamp": 0.0},
    ]])
    assert ["ok" in r for r in res] == [True, False, False, False, True]
    assert [r.get("error") for r in res[1:4]] == ["bad_request", "bad_request", "invalid_token"]
    assert len(core.store) == 2 and len(changes) == 2


def test_tokens_poses_and_static_frames_survive_reopening(tmp_path, registry):
    path = str(tmp_path / "bb.sqlite")
    store = Store(path)
    core = BlackboardCore(store, registry)
    a = post(core, "bbt_landmark", {"name": "a"}, geometry=square(0, 0, 1, 1), stamp=1.0)
    b = post(core, "bbt_segment", {"index": 7}, stamp=2.0)
    op(core, {"op": "update", "id": b["id"], "expected_version": 1, "attrs": {"index": 8}})
    c = post(core, "bbt_segment", {"index": 9}, stamp=3.0)
    op(core, {"op": "delete", "id": c["id"]})
    op(core, {"op": "pose", "parent": "local", "child": "vehicle", "pose": [1.0, 2.0, 0.5], "stamp": 4.0})
    op(core, {"op": "static", "parent": "vehicle", "child": "camera", "pose": [1.0, 0.0, 0.0]})
    store.close()

    store2 = Store(path)
    core2 = BlackboardCore(store2, registry)
    got = {t["id"]: t for t in core2.retrieve({})}
    assert set(got) == {a["id"], b["id"]}
    assert got[b["id"]]["version"] == 2 and got[b["id"]]["attrs"] == {"index": 8, "mode": "follow-road"}
    assert got[a["id"]]["geometry"] == square(0, 0, 1, 1)
    assert core2.lookup({"target": "local", "target_stamp": 4.0, "source": "camera", "source_stamp": 4.0})[0] == pytest.approx(1.0 + 0.8775825618903728)
    # ids are never reused after a delete
    d = post(core2, "bbt_segment", {"index": 10})
    assert d["id"] not in (a["id"], b["id"], c["id"])
    store2.close()


def test_monitor_matching_sees_new_updated_deleted_in_order(core):
    core.register_monitor("c1", "m1", Spec(type="bbt_segment", where=[AttrPredicate(path="index", op="<", value=10)]).model_dump(mode="json"))
    core.register_monitor("c1", "m2", Spec(type="bbt_landmark", geometry=Within(Polygon(points=[(0, 0), (5, 0), (5, 5), (0, 5)]))).model_dump(mode="json"))
    (res,), changes = core.apply_requests([[
        {"op": "post", "type": "bbt_segment", "attrs": {"index": 1}, "stamp": 0.0},
        {"op": "post", "type": "bbt_segment", "attrs": {"index": 50}, "stamp": 0.0},
        {"op": "post", "type": "bbt_landmark", "attrs": {"name": "in"}, "stamp": 0.0, "geometry": pt(1, 1)},
        {"op": "post", "type": "bbt_landmark", "attrs": {"name": "out"}, "stamp": 0.0, "geometry": pt(10, 1)},
    ]])
    evs = core.match_changes(changes)
    assert [(m.mid, e["kind"], e["token"]["attrs"].get("index", e["token"]["attrs"].get("name"))) for m, e in evs] == [
        ("m1", "new", 1), ("m2", "new", "in")]
    seg = res[0]["ok"]
    (_,), changes = core.apply_requests([[
        {"op": "update", "id": seg["id"], "expected_version": 1, "attrs": {"index": 5}},
        {"op": "delete", "id": seg["id"]},
    ]])
    assert [(m.mid, e["kind"]) for m, e in core.match_changes(changes)] == [("m1", "updated"), ("m1", "deleted")]
    # an update that takes a token out of the spec is still reported (the event shows the new state)
    t = op(core, {"op": "post", "type": "bbt_segment", "attrs": {"index": 2}, "stamp": 0.0})
    _, changes = core.apply_requests([[{"op": "update", "id": t["id"], "expected_version": 1, "attrs": {"index": 99}}]])
    assert [(e["kind"], e["token"]["attrs"]["index"]) for _, e in core.match_changes(changes)] == [("updated", 99)]
    assert core.drop_client("c1") == 2 and not core.monitors


def test_newest_monitor_reports_only_new_newest(core):
    core.register_monitor("c", "m", {"type": "bbt_segment", "newest": True})
    _, ch = core.apply_requests([[{"op": "post", "type": "bbt_segment", "attrs": {"index": 1}, "stamp": 5.0}]])
    assert len(core.match_changes(ch)) == 1
    _, ch = core.apply_requests([[{"op": "post", "type": "bbt_segment", "attrs": {"index": 2}, "stamp": 1.0}]])
    assert core.match_changes(ch) == []  # older than the newest: not the newest match


@pytest.mark.parametrize("geometry", [None, pt(1.5, -2.0), square(0, 0, 1, 2), {"kind": "polyline", "points": [[0, 0], [3, 4.5]]}])
def test_a_tokens_stored_bytes_are_its_wire_dict_packed(core, geometry):
    import msgpack

    t = post(core, "bbt_segment", {"index": 7}, stamp=2.5, geometry=geometry)
    rec = core.store.records[int(t["id"][1:])]
    assert msgpack.unpackb(rec.packed()) == t
    assert rec.packed() == msgpack.packb(rec.wire(), use_bin_type=True)
