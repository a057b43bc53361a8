"""The operation models shared by client and node: what the client builds validates on the node as the same
model, bad fields get the documented typed errors, and the replies keep their wire form."""

from __future__ import annotations

import dataclasses
import math

import msgpack
import pytest

from blackboard import BadRequestError, BadSpecError, InvalidTokenError, Spec
from blackboard.core import Stats
from blackboard.ops import (
    DeleteOp,
    FramesRequest,
    LookupRequest,
    MonitorCancel,
    MonitorRegister,
    PoseOp,
    PostOp,
    RetrieveRequest,
    StaticOp,
    UpdateOp,
    parse_monitor,
    parse_write,
    plain_post,
)
from blackboard.replies import FrameEdge, FrameListing, NodeStats


def _over_the_wire(obj):
    return msgpack.unpackb(msgpack.packb(obj, use_bin_type=True))


@pytest.mark.parametrize(
    "op",
    [
        PostOp.trusted({"op": "post", "type": "t", "attrs": {"a": 1}, "frame": "world", "stamp": 1.5, "source": "s",
                        "geometry": {"kind": "point", "x": 1.0, "y": 2.0}, "reply": "id"}),
        UpdateOp.trusted({"op": "update", "id": "t7", "expected_version": 3, "attrs": None, "frame": None, "stamp": 2.0,
                          "geometry": None}, {"op", "id", "expected_version", "stamp", "geometry"}),
        DeleteOp.trusted({"op": "delete", "id": "t7", "expected_version": None}, {"op", "id"}),
        PoseOp.trusted({"op": "pose", "parent": "local", "child": "vehicle", "pose": (1.0, 2.0, 0.5), "stamp": 3.0, "hold": None}),
        StaticOp.trusted({"op": "static", "parent": "vehicle", "child": "camera", "pose": (1.0, 0.0, 0.0)}),
    ],
)
def test_what_the_client_builds_the_node_validates_as_the_same_write(op):
    back = parse_write(_over_the_wire(op.wire()))
    assert type(back) is type(op) and back == op
    assert back.model_fields_set == op.model_fields_set  # an update keeps what it leaves alone


def test_update_sends_only_what_it_changes():
    op = UpdateOp.trusted({"op": "update", "id": "t1", "expected_version": 1, "attrs": None, "frame": None, "stamp": None,
                           "geometry": None}, {"op", "id", "expected_version", "geometry"})
    assert op.wire() == {"op": "update", "id": "t1", "expected_version": 1, "geometry": None}


def test_read_requests_round_trip():
    spec = Spec(type="bbt_segment", limit=3)
    reg = MonitorRegister.trusted({"client": "c-1", "mid": "m1", "spec": spec, "cancel": False}, {"client", "mid", "spec"})
    assert parse_monitor(_over_the_wire(reg.wire())) == reg
    cancel = MonitorCancel.trusted({"client": "c-1", "mid": "m1", "cancel": True})
    assert parse_monitor(_over_the_wire(cancel.wire())) == cancel
    look = LookupRequest.trusted({"target": "world", "target_stamp": None, "source": "vehicle", "source_stamp": 2.0})
    assert LookupRequest.parse(_over_the_wire(look.wire())) == look
    req = RetrieveRequest.from_wire(spec.model_dump(mode="json"), {"frame": "vehicle", "stamp": "10.5"})
    assert req == RetrieveRequest(spec=spec, frame="vehicle", frame_stamp=10.5)
    assert req.selector_parameters() == "frame=vehicle;stamp=10.5"
    envelope = {"spec": spec.model_dump(mode="json"), "frame": "world"}
    assert RetrieveRequest.from_wire(envelope, {}) == RetrieveRequest(spec=spec, frame="world")
    assert FramesRequest.parse({}) == FramesRequest()


@pytest.mark.parametrize(
    "raw, err, names",
    [
        ("garbage", BadRequestError, "object"),
        ({"op": "explode"}, BadRequestError, "explode"),
        ({"type": "t", "stamp": "1.0"}, InvalidTokenError, "stamp"),
        ({"type": "t", "stamp": math.nan}, InvalidTokenError, "stamp"),
        ({"type": "t", "stamp": True}, InvalidTokenError, "stamp"),
        ({"type": "t", "stamp": 0.0, "frame": "a/b"}, InvalidTokenError, "frame"),
        ({"type": "t", "stamp": 0.0, "colour": "red"}, InvalidTokenError, "colour"),
        ({"type": "t", "stamp": 0.0, "reply": "all"}, InvalidTokenError, "reply"),
        ({"op": "update", "id": "t1", "attrs": {}}, BadRequestError, "expected_version"),
        ({"op": "update", "id": "t1", "expected_version": "2"}, BadRequestError, "expected_version"),
        ({"op": "update", "id": 5, "expected_version": 1}, BadRequestError, "id"),
        ({"op": "delete", "id": "t1", "expected_version": 1.0}, BadRequestError, "expected_version"),
        ({"op": "pose", "parent": "local", "child": "vehicle", "pose": [0, 0], "stamp": 0.0}, InvalidTokenError, "pose"),
        ({"op": "pose", "parent": "local", "child": "vehicle", "pose": [0, 0, 0], "stamp": 0.0, "hold": -1}, InvalidTokenError, "hold"),
        ({"op": "static", "parent": "", "child": "camera", "pose": [0, 0, 0]}, InvalidTokenError, "parent"),
    ],
)
def test_bad_writes_get_typed_errors_naming_the_field(raw, err, names):
    with pytest.raises(err, match=names) as ei:
        parse_write(raw)
    assert type(ei.value) is err


def test_bad_read_requests_get_typed_errors():
    with pytest.raises(BadSpecError, match="limit"):
        RetrieveRequest.from_wire({"limit": 0}, {})
    with pytest.raises(BadSpecError, match="frame"):
        RetrieveRequest.from_wire({}, {"frame": "a b"})
    with pytest.raises(BadRequestError, match="stamp"):
        RetrieveRequest.from_wire({}, {"stamp": "soon"})
    with pytest.raises(BadRequestError, match="mid"):
        parse_monitor({"client": "c", "mid": "a/b", "spec": {}})
    with pytest.raises(BadSpecError, match="spec"):
        parse_monitor({"client": "c", "mid": "m", "spec": {"limit": -1}})
    with pytest.raises(BadRequestError, match="colour"):
        parse_monitor({"client": "c", "mid": "m", "spec": {}, "colour": 1})
    with pytest.raises(InvalidTokenError, match="target"):
        LookupRequest.parse({"target": None, "source": "vehicle"})
    with pytest.raises(BadRequestError):
        FramesRequest.parse([1])


def test_replies_keep_their_wire_form():
    listing = FrameListing(edges=(FrameEdge(parent="vehicle", child="camera", static=True),
                                  FrameEdge(parent="local", child="vehicle", static=False, oldest=1.0, newest=2.0)))
    wire = listing.wire()
    assert wire == {"edges": [{"parent": "vehicle", "child": "camera", "static": True},
                              {"parent": "local", "child": "vehicle", "static": False, "oldest": 1.0, "newest": 2.0}]}
    assert FrameListing.model_validate(_over_the_wire(wire)) == listing
    assert listing.edge("local", "vehicle").newest == 2.0 and listing.edge("world", "local") is None
    # the counters keep the node's names (reports and tools read them by name)
    assert set(NodeStats.model_fields) == {f.name for f in dataclasses.fields(Stats)} | {"tokens", "monitors"}
    assert Stats(posts=3).snapshot(tokens=2, monitors=1) == NodeStats(posts=3, tokens=2, monitors=1)


_PLAIN = {"op": "post", "type": "t", "attrs": {"a": 1}, "frame": "world", "stamp": 1.5, "source": "s",
          "geometry": {"kind": "point", "x": 1.0, "y": 2.0}, "reply": "id"}
_ODD_VALUES = ["", "world", "a b", "w\n", "x" * 128, "x" * 129, "id", "post", "update", None, 0, 1, 1.5, -0.0, math.inf,
               math.nan, True, b"world", ["world"], {"a": 1}, (1.0, 2.0)]


def test_the_plain_post_shortcut_accepts_only_what_post_op_accepts_with_the_same_values():
    cases = [dict(_PLAIN), {"type": "t", "stamp": 0.0}]
    for key in _PLAIN:
        cases.append({k: v for k, v in _PLAIN.items() if k != key})
        cases += [{**_PLAIN, key: v} for v in _ODD_VALUES]
    cases += [{**_PLAIN, "extra": 1}, {**_PLAIN, "source": "é" * 128}, {**_PLAIN, "source": "é" * 129}]
    accepted = 0
    for raw in cases:
        fields = plain_post(raw)
        if fields is None:
            continue
        accepted += 1
        op = PostOp.parse(raw)
        assert fields == (op.type, op.attrs, op.frame, op.stamp, op.source, op.geometry, op.reply), raw
    assert accepted >= 20
    assert plain_post([_PLAIN]) is None and plain_post(PostOp.parse(_PLAIN)) is None
