"""Per-type token limits: the node refuses a token past its type's bytes or points with `token_too_large`
naming the type and the limit; the rest of the batch and everything stored are kept (pure core, then a
real node over Zenoh)."""

from __future__ import annotations

import asyncio
import math

import pytest

from blackboard import Polygon, Spec, TokenTooLargeError
from blackboard.errors import InvalidTokenError, error_from_wire
from blackboard.limits import DEFAULT_LIMIT, LIMITS, check_token_size, limit_for
from tests.blackboard.conftest import post
from tests.blackboard.sample_types import Landmark, Segment

pytestmark = pytest.mark.timeout(90)

BIG_NAME = "x" * (DEFAULT_LIMIT.max_bytes + 1)  # a test type has no limit of its own: the default applies


def _ring(n: int) -> list[list[float]]:
    """Return a valid polygon of `n` vertices: a circle of radius 10 m."""
    return [[10.0 * math.cos(2 * math.pi * k / n), 10.0 * math.sin(2 * math.pi * k / n)] for k in range(n)]


def test_the_table_names_each_limit_and_unknown_types_get_the_default():
    assert limit_for("local_path_plan") is LIMITS["local_path_plan"] and limit_for("bbt_landmark") == DEFAULT_LIMIT
    check_token_size("mission", 1024 * 1024, 0)  # at the limit: accepted
    with pytest.raises(TokenTooLargeError, match=r"'mission' token of 1048577 bytes exceeds the limit of 1048576 bytes for its type"):
        check_token_size("mission", 1024 * 1024 + 1, 0)
    with pytest.raises(TokenTooLargeError, match=r"4097 geometry points exceeds the limit of 4096 points for a type without a limit"):
        check_token_size("whatever", 10, 4097)
    assert issubclass(TokenTooLargeError, InvalidTokenError)  # handled wherever an invalid token is


def test_the_core_refuses_an_oversized_token_and_keeps_the_rest_of_the_batch(core):
    kept = post(core, "bbt_landmark", {"name": "kept"})
    (res,), changes = core.apply_requests([[
        {"op": "post", "type": "bbt_landmark", "attrs": {"name": BIG_NAME}, "stamp": 0.0, "source": "t"},
        {"op": "post", "type": "bbt_landmark", "attrs": {"name": "after"}, "stamp": 0.0, "source": "t"},
        {"op": "post", "type": "bbt_segment", "attrs": {"index": 1}, "stamp": 0.0, "source": "t",
         "geometry": {"kind": "polygon", "points": _ring(DEFAULT_LIMIT.max_points + 1)}},
        {"op": "update", "id": kept["id"], "expected_version": 1, "attrs": {"name": BIG_NAME}},
    ]])
    assert [r.get("error") for r in res] == ["token_too_large", None, "token_too_large", "token_too_large"]
    err = error_from_wire(res[0])
    assert isinstance(err, TokenTooLargeError) and "'bbt_landmark'" in err.message and f"limit of {DEFAULT_LIMIT.max_bytes} bytes" in err.message
    assert "'bbt_segment'" in res[2]["message"] and f"limit of {DEFAULT_LIMIT.max_points} points" in res[2]["message"]
    assert len(changes) == 1  # only "after"
    names = sorted(r["attrs"]["name"] for r in core.retrieve({"type": "bbt_landmark"}))
    assert names == ["after", "kept"]
    (stored,) = [r for r in core.retrieve({"type": "bbt_landmark"}) if r["id"] == kept["id"]]
    assert stored["version"] == 1 and stored["attrs"]["name"] == "kept"


async def test_a_client_gets_a_clear_error_and_the_node_keeps_serving(bb):
    first = await bb.post(Landmark(name="first"), stamp=0.0)
    big, small, many = (bb.post(Landmark(name=BIG_NAME), stamp=0.0), bb.post(Landmark(name="second"), stamp=0.0),
                        bb.post(Segment(index=7), stamp=0.0, geometry=Polygon(points=_ring(DEFAULT_LIMIT.max_points + 1))))
    outcomes = await asyncio.gather(big, small, many, return_exceptions=True)
    assert isinstance(outcomes[0], TokenTooLargeError) and "'bbt_landmark' token of" in str(outcomes[0]), outcomes[0]
    assert isinstance(outcomes[2], TokenTooLargeError) and "geometry points" in str(outcomes[2]), outcomes[2]
    assert outcomes[1].version == 1
    with pytest.raises(TokenTooLargeError, match="exceeds the limit"):
        await bb.update(first.id, Landmark(name=BIG_NAME), expected_version=1)
    names = {t.attrs.name for t in await bb.retrieve(Spec(type="bbt_landmark"))}
    assert {"first", "second"} <= names and BIG_NAME not in names
    (still,) = [t for t in await bb.retrieve(Spec(type="bbt_landmark")) if t.id == first.id]
    assert still.version == 1 and still.attrs.name == "first"
