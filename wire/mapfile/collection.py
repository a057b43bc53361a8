"""A validated world or map file (`MapFile`): objects, path graph, sun, start and weather, with look-ups and GeoJSON output."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from wire.mapfile.appearance import Sun, Weather
from wire.mapfile.features import PathEdge, PathNode, StartPose, WorldObject
from wire.mapfile.problems import Problem, WorldFileError
from wire.terrainfile import TerrainRaster, TerrainRef
from wire.mapfile.references import cross_check

__all__ = ["MapFile"]


class MapFile:
    """A validated world or map file: objects, path graph, sun and start, with look-ups.

    Construct through `load_map_file` / `parse_map_file`, or directly (the constructor validates the
    cross references and raises `WorldFileError` with `source` as the file name). The simulator's
    `vehicle_sim.worldfile.World` adds ground queries to it.
    """

    def __init__(
        self,
        *,
        name: str,
        objects: Iterable[WorldObject],
        nodes: Iterable[PathNode] = (),
        edges: Iterable[PathEdge] = (),
        sun: Sun | None = None,
        start: StartPose | None = None,
        source: str = "<memory>",
        weather: Weather | None = None,
        actors: Iterable[dict] = (),
        terrain: TerrainRef | None = None,
        terrain_raster: TerrainRaster | None = None,
    ) -> None:
        self.name = name
        #: the optional `terrain` entry (a raster file beside this one, `wire.terrainfile`) and its raster, loaded
        self.terrain: TerrainRef | None = terrain
        self.terrain_raster: TerrainRaster | None = terrain_raster
        if (terrain is None) != (terrain_raster is None):
            raise WorldFileError(source, [Problem(field="terrain", message="a terrain entry needs its raster, and a raster its entry")])
        #: objects not on the map (the world file's optional `actors` list, truth for the simulator only):
        #: kept as written; `vehicle_sim.worldfile.World` validates them
        self.actors: tuple[dict, ...] = tuple(actors)
        self.objects: tuple[WorldObject, ...] = tuple(objects)
        self.nodes: tuple[PathNode, ...] = tuple(nodes)
        self.edges: tuple[PathEdge, ...] = tuple(edges)
        self.sun: Sun = sun or Sun(azimuth_deg=200.0, elevation_deg=40.0)
        self.start: StartPose | None = start
        self.weather: Weather | None = weather
        self.source = source
        self._obj_by_id = {o.id: o for o in self.objects}
        self._node_by_id = {n.id: n for n in self.nodes}
        self._edge_by_id = {e.id: e for e in self.edges}
        self._obj_index = {o.id: i for i, o in enumerate(self.objects)}
        problems = cross_check(self.objects, self.nodes, self.edges, self.start)
        if problems:
            raise WorldFileError(source, problems)

    # ---- lookup -------------------------------------------------------------------------

    def object(self, object_id: str) -> WorldObject:
        """Return the object with this id (KeyError if absent)."""
        return self._obj_by_id[object_id]

    def has_object(self, object_id: str) -> bool:
        """Return True when an object with this id exists."""
        return object_id in self._obj_by_id

    def object_index(self, object_id: str) -> int:
        """Return the index of the object with this id in `objects`."""
        return self._obj_index[object_id]

    def node(self, node_id: str) -> PathNode:
        """Return the path node with this id (KeyError if absent)."""
        return self._node_by_id[node_id]

    def edge(self, edge_id: str) -> PathEdge:
        """Return the path edge with this id (KeyError if absent)."""
        return self._edge_by_id[edge_id]

    def place(self, name: str) -> PathNode:
        """Return the node named `name` (KeyError listing the known names if absent)."""
        for n in self.nodes:
            if n.name == name:
                return n
        raise KeyError(f"no place named {name!r} in world {self.name!r}; known: {sorted(self.place_names())}")

    def place_names(self) -> tuple[str, ...]:
        """Return the names of every named node."""
        return tuple(n.name for n in self.nodes if n.name is not None)

    def objects_of_kind(self, *kinds: str) -> tuple[WorldObject, ...]:
        """Return the objects whose kind is one of `kinds`."""
        return tuple(o for o in self.objects if o.kind in kinds)

    def edges_at(self, node_id: str) -> tuple[PathEdge, ...]:
        """Return the edges touching node `node_id`."""
        return tuple(e for e in self.edges if node_id in (e.from_node, e.to_node))

    @property
    def intersections(self) -> tuple[PathNode, ...]:
        """Return the intersection nodes."""
        return tuple(n for n in self.nodes if n.node_kind == "intersection")

    def bounds(self, margin: float = 0.0) -> tuple[float, float, float, float]:
        """Return (xmin, ymin, xmax, ymax) [m] of every object footprint, grown by `margin` [m]."""
        pts = [o.vertices for o in self.objects]
        if self.start is not None:
            pts.append(np.array([[self.start.x, self.start.y]]))
        if not pts:
            return (-margin, -margin, margin, margin)
        a = np.vstack(pts)
        lo, hi = a.min(axis=0) - margin, a.max(axis=0) + margin
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    # ---- output ------------------------------------------------------------------------

    def to_geojson(self) -> dict:
        """Return the world as a GeoJSON FeatureCollection dict (the file format)."""
        coll: dict[str, Any] = {"type": "FeatureCollection", "name": self.name}
        coll["sun"] = self.sun.model_dump()
        if self.start is not None:
            coll["start"] = self.start.model_dump(exclude_none=True)
        if self.weather is not None:
            coll["weather"] = self.weather.model_dump()
        if self.actors:
            coll["actors"] = list(self.actors)
        if self.terrain is not None:
            coll["terrain"] = self.terrain.model_dump()
        feats = [o.to_feature() for o in self.objects]
        feats += [n.to_feature() for n in self.nodes]
        feats += [e.to_feature() for e in self.edges]
        coll["features"] = feats
        return coll

    def save(self, path: str | Path) -> Path:
        """Write the world as GeoJSON to `path` (deterministic: one feature per line)."""
        path = Path(path)
        coll = self.to_geojson()
        feats = coll.pop("features")
        head = json.dumps(coll, sort_keys=False)[:-1]
        body = ",\n".join(json.dumps(_round(f), sort_keys=False) for f in feats)
        path.write_text(f'{head}, "features": [\n{body}\n]}}\n')
        return path

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(name={self.name!r}, objects={len(self.objects)}, nodes={len(self.nodes)}, "
            f"edges={len(self.edges)}, source={self.source!r})"
        )


def _round(obj: Any, nd: int = 4) -> Any:
    if isinstance(obj, float):
        r = round(obj, nd)
        return 0.0 if r == 0 else r
    if isinstance(obj, dict):
        return {k: _round(v, nd) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_round(v, nd) for v in obj]
    return obj
