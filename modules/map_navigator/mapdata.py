"""The MAP as the MAP NAVIGATOR holds it: the loaded map file and object descriptions copied from it.

Only the MAP NAVIGATOR reads the map file (seed §2.3.7). Coordinates are in the `world` frame [m].
"""

from __future__ import annotations

import math
from functools import cached_property
from pathlib import Path

import shapely
from wire.mapfile import MapFile, PathNode, WorldFileError, WorldObject, load_map_file

from modules.vocabulary import MapObject

__all__ = ["MapData", "load_map", "map_object", "WorldFileError"]


def map_object(obj: WorldObject) -> MapObject:
    """Return the object description (vocabulary `MapObject`) copied from a map object."""
    return MapObject(
        object_id=obj.id, kind=obj.kind, role=obj.role, name=obj.name,
        cost=obj.cost if math.isfinite(obj.cost) else None,
        colour=obj.colour,
        shape=obj.shape.model_dump(),
        polygon=obj.polygon, center=obj.center, radius=obj.radius,
    )


class MapData:
    """A loaded map with the look-ups route planning needs: places, intersection areas, descriptions."""

    def __init__(self, world: MapFile) -> None:
        self.world = world

    @property
    def name(self) -> str:
        """Return the map's name."""
        return self.world.name

    def find_place(self, name: str) -> PathNode | None:
        """Return the node named `name`, else the node whose id is `name`, else None."""
        for n in self.world.nodes:
            if n.name == name:
                return n
        for n in self.world.nodes:
            if n.id == name:
                return n
        return None

    def place_names(self) -> tuple[str, ...]:
        """Return the names of every named place, sorted."""
        return tuple(sorted(self.world.place_names()))

    @cached_property
    def _intersection_areas(self) -> dict[str, WorldObject]:
        out: dict[str, WorldObject] = {}
        areas = self.world.objects_of_kind("intersection")
        for n in self.world.nodes:
            oid = getattr(n, "object_id", None)
            if oid is not None and self.world.has_object(oid):
                out[n.id] = self.world.object(oid)
                continue
            p = shapely.Point(n.x, n.y)
            for o in areas:
                if o.footprint.covers(p):
                    out[n.id] = o
                    break
        return out

    def intersection_area(self, node_id: str) -> WorldObject | None:
        """Return the intersection object covering node `node_id`, or None."""
        return self._intersection_areas.get(node_id)

    @cached_property
    def descriptions(self) -> dict[str, MapObject]:
        """Return the object description of every map object, by id."""
        return {o.id: map_object(o) for o in self.world.objects}

    @cached_property
    def _tree(self) -> shapely.STRtree:
        return shapely.STRtree([o.footprint for o in self.world.objects])

    def objects_near(self, line: shapely.LineString, distance: float) -> list[tuple[float, WorldObject]]:
        """Return (distance [m], object) for every object within `distance` [m] of `line`, nearest first."""
        idx = self._tree.query(line, predicate="dwithin", distance=distance)
        found = [(float(self.world.objects[i].footprint.distance(line)), self.world.objects[i]) for i in idx]
        found.sort(key=lambda t: (t[0], t[1].id))
        return found


def load_map(path: str | Path) -> MapData:
    """Load and validate the map file (a path, or a name like "campus" for worlds/campus.map.geojson)."""
    return MapData(load_map_file(path, kind="map"))
