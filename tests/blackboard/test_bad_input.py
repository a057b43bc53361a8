"""Bad input on the wire: hundreds of generated garbage/malformed payloads each get a typed error reply,
and the node stays up and keeps serving."""

from __future__ import annotations

import json
import math
import threading

import msgpack
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from wire.session import open_session
from blackboard.codec import decode
from wire.keys import BlackboardKeys

pytestmark = pytest.mark.timeout(120)

KNOWN = {"bad_request", "unknown_type", "invalid_token", "token_too_large", "bad_spec", "version_conflict", "not_found",
         "unknown_frame", "extrapolation", "past_extrapolation", "future_extrapolation"}
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow], derandomize=True)


class Raw:
    """A raw zenoh session speaking to the node like any standard tool would (blocking gets)."""

    def __init__(self, node) -> None:
        self.keys = BlackboardKeys(node.namespace)
        self.s = open_session(node.client_net())

    def get(self, key: str, payload: bytes, *, as_json: bool = False) -> tuple[bool, object]:
        done = threading.Event()
        box: list = []
        self.s.get(key, payload, as_json=as_json, timeout=10, on_reply=lambda r: box.append(r), on_done=done.set)
        assert done.wait(15), f"no answer from {key}"
        assert len(box) == 1, f"{key}: expected one reply, got {len(box)} (node down?)"
        r = box[0]
        return r.ok, decode(r.payload, as_json=r.is_json)

    def expect_error(self, key: str, payload: bytes, *, as_json: bool = False, codes: set[str] = KNOWN) -> str:
        ok, obj = self.get(key, payload, as_json=as_json)
        assert not ok, f"{key} accepted {payload[:80]!r}: {str(obj)[:200]}"
        assert isinstance(obj, dict) and obj.get("error") in codes and obj.get("message"), obj
        return obj["error"]


@pytest.fixture(scope="module")
def raw(node):
    r = Raw(node)
    yield r
    r.s.close()


def mp(obj) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-2**40, 2**40) | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=12),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4),
    max_leaves=12,
)


@SETTINGS
@given(data=st.binary(min_size=1, max_size=200))
def test_garbage_bytes_get_error_replies_or_valid_answers(raw, data):
    for key in (raw.keys.post, raw.keys.batch, raw.keys.update, raw.keys.delete, raw.keys.lookup, raw.keys.monitor):
        ok, obj = raw.get(key, data)
        if not ok:
            assert isinstance(obj, dict) and obj["error"] in KNOWN
        else:  # random bytes decoding to a valid request is possible only for the batch (a list)
            assert key == raw.keys.batch and isinstance(obj, list)
            assert all("error" in r for r in obj)


@SETTINGS
@given(name=st.text(min_size=1, max_size=20).filter(lambda s: s not in {"bbt_landmark", "bbt_segment", "bbt_obstacle"}), attrs=json_values, as_json=st.booleans())
def test_unknown_types_are_refused(raw, name, attrs, as_json):
    body = {"type": name, "attrs": attrs, "stamp": 0.0}
    payload = json.dumps(body).encode() if as_json else mp(body)
    assert raw.expect_error(raw.keys.post, payload, as_json=as_json) in {"unknown_type", "invalid_token"}


@SETTINGS
@given(index=json_values.filter(lambda v: not isinstance(v, int) and not (isinstance(v, float) and v.is_integer()) and not (isinstance(v, str) and v.strip().lstrip("+-").isdigit())),
       extra=st.dictionaries(st.text(min_size=1, max_size=6).filter(lambda k: k not in ("index", "mode")), json_values, max_size=2))
def test_malformed_attrs_are_invalid_tokens(raw, index, extra):
    body = {"type": "bbt_segment", "attrs": {"index": index, **extra}, "stamp": 1.0}
    assert raw.expect_error(raw.keys.post, mp(body)) == "invalid_token"


bad_coord = st.sampled_from([math.nan, math.inf, -math.inf, "x", None, True])
bad_geometries = st.one_of(
    st.builds(lambda c: {"kind": "point", "x": c, "y": 0.0}, bad_coord),
    st.builds(lambda n: {"kind": "polygon", "points": [[float(i), 0.0] for i in range(n)]}, st.integers(0, 2)),
    st.builds(lambda n: {"kind": "polyline", "points": [[0.0, 0.0]] * n}, st.integers(0, 1)),
    st.builds(lambda a: {"kind": "polygon", "points": [[0, 0], [a, a], [a, 0], [0, a]]}, st.floats(0.1, 100)),  # bow-tie
    st.builds(lambda a: {"kind": "polygon", "points": [[0, 0], [a, 0], [2 * a, 0]]}, st.floats(0.1, 100)),  # zero area
    st.builds(lambda k: {"kind": k, "points": [[0, 0], [1, 1], [0, 1]]}, st.text(max_size=8).filter(lambda k: k not in ("polygon", "polyline"))),
    st.builds(lambda p: {"kind": "polyline", "points": p}, st.lists(st.lists(st.floats(allow_nan=False), min_size=0, max_size=3).filter(lambda l: len(l) != 2), min_size=2, max_size=4)),
    json_values.filter(lambda v: not isinstance(v, dict) and v is not None),
)


@SETTINGS
@given(geometry=bad_geometries)
def test_invalid_geometry_is_an_invalid_token(raw, geometry):
    body = {"type": "bbt_landmark", "attrs": {"name": "g"}, "stamp": 1.0, "geometry": geometry}
    assert raw.expect_error(raw.keys.post, mp(body)) == "invalid_token"


bad_specs = st.one_of(
    json_values.filter(lambda v: not isinstance(v, dict)),
    st.builds(lambda op: {"where": [{"path": "a", "op": op, "value": 1}]}, st.text(max_size=4).filter(lambda o: o not in ("==", "!=", "<", "<=", ">", ">=", "in", "exists"))),
    st.builds(lambda n: {"limit": n}, st.integers(-10**6, 0) | st.text(max_size=3).filter(lambda s: not s.strip().isdigit())),
    st.builds(lambda k, v: {k: v}, st.text(min_size=1, max_size=8).filter(lambda k: k not in ("type", "where", "geometry", "any_of", "newest", "limit")), json_values),
    st.builds(lambda g: {"geometry": {"op": "within", "polygon": g}}, bad_geometries),
    st.builds(lambda d: {"geometry": {"op": "near", "geometry": {"kind": "point", "x": 0, "y": 0}, "distance": d}}, st.floats(max_value=-1e-9) | st.just(math.nan)),
    st.builds(lambda f: {"geometry": {"op": "nearest", "point": {"kind": "point", "x": 0, "y": 0}, "k": 1, "frame": f}}, st.text(max_size=10).filter(lambda f: not f or any(not (c.isascii() and (c.isalnum() or c in "_.-")) for c in f))),
    st.builds(lambda s: {"any_of": [s]}, st.just({"where": "nope"})),
)


@SETTINGS
@given(spec=bad_specs, as_json=st.booleans())
def test_bad_specs_get_bad_spec_errors(raw, spec, as_json):
    try:
        payload = json.dumps(spec, allow_nan=False).encode() if as_json else mp(spec)
    except ValueError:
        payload, as_json = mp(spec), False
    assert raw.expect_error(raw.keys.retrieve, payload, as_json=as_json) == "bad_spec"


@SETTINGS
@given(tid=json_values, version=json_values)
def test_updates_and_deletes_of_unknown_or_malformed_ids_are_refused(raw, tid, version):
    raw.expect_error(raw.keys.update, mp({"id": tid, "expected_version": version, "attrs": {"index": 1}}), codes={"not_found", "bad_request", "invalid_token"})
    raw.expect_error(raw.keys.delete, mp({"id": tid}), codes={"not_found", "bad_request"})


def test_node_still_serves_after_the_barrage(raw):
    for junk in (b"\xc1", b"\x93\x01", mp({"op": "post"}), mp([{"op": "pose"}])):
        raw.get(raw.keys.post, junk)
    ok, tok = raw.get(raw.keys.post, mp({"type": "bbt_segment", "attrs": {"index": 4242}, "stamp": 1.0}))
    assert ok and tok["attrs"]["index"] == 4242
    ok, got = raw.get(raw.keys.retrieve, mp({"type": "bbt_segment", "where": [{"path": "index", "op": "==", "value": 4242}]}))
    assert ok and [t["id"] for t in got] == [tok["id"]]
    ok, stats = raw.get(raw.keys.stats, b"")
    assert ok and stats["errors"] >= 4  # (≥ 300 when run after the generated cases above)
