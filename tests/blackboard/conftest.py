"""Fixtures for the blackboard tests: a pure core on an in-memory store, and real nodes over Zenoh."""

from __future__ import annotations

import pytest

from blackboard.core import BlackboardCore
from blackboard.registry import TypeRegistry
from blackboard.store import Store
from tests.blackboard import sample_types  # noqa: F401 - registers the sample types in default_registry
from tests.blackboard.sample_types import Landmark, Obstacle, Segment


@pytest.fixture
def registry() -> TypeRegistry:
    reg = TypeRegistry()
    reg.register("bbt_landmark", Landmark)
    reg.register("bbt_segment", Segment)
    reg.register("bbt_obstacle", Obstacle)
    return reg


@pytest.fixture
def core(registry: TypeRegistry):
    store = Store(":memory:")
    c = BlackboardCore(store, registry)
    yield c
    store.close()


def post(core: BlackboardCore, type: str, attrs: dict, *, stamp: float = 0.0, frame: str = "world", geometry=None, source: str = "t") -> dict:
    """Post one token through the core; return its wire dict (raise the typed error)."""
    from blackboard.errors import error_from_wire

    (res,), _ = core.apply_requests([[{"op": "post", "type": type, "attrs": attrs, "stamp": stamp, "frame": frame, "geometry": geometry, "source": source}]])
    if "ok" not in res[0]:
        raise error_from_wire(res[0])
    return res[0]["ok"]


def op(core: BlackboardCore, o: dict):
    """Apply one op; return its ok value or raise its typed error."""
    from blackboard.errors import error_from_wire

    (res,), _ = core.apply_requests([[o]])
    if "ok" not in res[0]:
        raise error_from_wire(res[0])
    return res[0]["ok"]


def pt(x: float, y: float) -> dict:
    return {"kind": "point", "x": x, "y": y}


def square(x0: float, y0: float, x1: float, y1: float) -> dict:
    return {"kind": "polygon", "points": [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]}


@pytest.fixture(scope="module")
def node():
    """A real blackboard node in its own OS process, on a free loopback port."""
    from blackboard.testing import start_node

    with start_node(namespace="t", types=("tests.blackboard.sample_types",)) as n:
        yield n


@pytest.fixture
async def bb(node):
    """A client of the module's node."""
    from blackboard import BlackboardClient

    async with BlackboardClient(node.client_net(), source="test", timeout=10.0) as c:
        yield c
