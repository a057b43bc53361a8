"""The references between a file's features: edge ends at their nodes, path objects, place names, the start node."""

from __future__ import annotations

import math

from wire.mapfile.features import PathEdge, PathNode, StartPose, WorldObject
from wire.mapfile.problems import Problem

__all__ = ["EDGE_END_TOLERANCE", "cross_check"]

#: Largest allowed gap between an edge's end and its node [m].
EDGE_END_TOLERANCE = 0.5


def cross_check(
    objects: tuple[WorldObject, ...] | list[WorldObject],
    nodes: tuple[PathNode, ...] | list[PathNode],
    edges: tuple[PathEdge, ...] | list[PathEdge],
    start: StartPose | None,
    ignore: set[str] = frozenset(),  # type: ignore[assignment]
) -> list[Problem]:
    """Check references between features: edge ends, path objects, names, start node (ids in `ignore` count as present)."""
    problems: list[Problem] = []
    obj_by_id = {o.id: o for o in objects}
    node_by_id = {n.id: n for n in nodes}
    ids: dict[str, str] = {}
    for coll, label in ((objects, "object"), (nodes, "node"), (edges, "edge")):
        for item in coll:
            if item.id in ids:
                problems.append(Problem(feature_id=item.id, field="properties.id", message=f"duplicate id ({ids[item.id]} and {label})"))
            ids[item.id] = label
    names: dict[str, str] = {}
    for n in nodes:
        if n.name is not None:
            if n.name in names:
                problems.append(Problem(feature_id=n.id, field="properties.name", message=f"place name {n.name!r} also used by node {names[n.name]!r}"))
            names[n.name] = n.id
        if n.object_id is not None and n.object_id not in obj_by_id and n.object_id not in ignore:
            problems.append(Problem(feature_id=n.id, field="properties.object", message=f"unknown object {n.object_id!r}"))
    for e in edges:
        for end, nid, pt in (("from", e.from_node, e.coords[0]), ("to", e.to_node, e.coords[-1])):
            node = node_by_id.get(nid)
            if node is None:
                if nid not in ignore:
                    problems.append(Problem(feature_id=e.id, field=f"properties.{end}", message=f"unknown node {nid!r}"))
                continue
            gap = math.hypot(pt[0] - node.x, pt[1] - node.y)
            if gap > EDGE_END_TOLERANCE:
                problems.append(Problem(feature_id=e.id, field="geometry.coordinates", message=f"{end} end is {gap:.2f} m from node {nid!r} (max {EDGE_END_TOLERANCE} m)"))
        for oid in e.path_objects:
            o = obj_by_id.get(oid)
            if o is None:
                if oid not in ignore:
                    problems.append(Problem(feature_id=e.id, field="properties.path_objects", message=f"unknown object {oid!r}"))
            elif not o.traversable:
                problems.append(Problem(feature_id=e.id, field="properties.path_objects", message=f"object {oid!r} ({o.kind}) is not traversable"))
    if start is not None and start.node is not None and start.node not in node_by_id and start.node not in ignore:
        problems.append(Problem(field="start.node", message=f"unknown node {start.node!r}"))
    return problems
