"""Map objects: the OBJECT DATA BASE entries the MAP NAVIGATOR copies into route segments.

Geometry is in the `world` frame (x east, y north) [m]. Mirrors the world/map GeoJSON schema.
"""

from __future__ import annotations

from typing import Literal

from pydantic import model_validator

from modules.vocabulary._base import token_type
from wire.mapfile import ColourType, FlatShape, MapColour, PostShape, PrismShape, Shape, SlopeShape, StairsShape, TreeShape
from modules.vocabulary._base import XY, Frozen, NonNeg, Ring, finite

__all__ = [
    "ObjectRole", "ColourType", "MapColour", "FlatShape", "SlopeShape", "StairsShape", "PrismShape",
    "TreeShape", "PostShape", "Shape", "MapObject", "MapPlaces",
]

#: Role of an object in navigation (seed §2.3.7).
ObjectRole = Literal["path", "landmark", "obstacle", "none"]


@token_type("map_object")
class MapObject(Frozen):
    """One object of the map (world frame): polygon or center+radius, role, cost, colour, 3-D shape.

    Copied from `wire.mapfile.WorldObject` (same colour and shape models): the colour is what the map
    says (a colour type such as GRAY, a nominal colour), never how the surface looks in the world.
    `cost` is the traversal cost multiplier per metre; None means not traversable. Exactly one of
    `polygon` (exterior ring [m]) and `center` (with `radius` [m]) is given.
    """

    object_id: str
    kind: str
    role: ObjectRole
    name: str | None = None
    cost: NonNeg | None = None
    colour: MapColour | None = None
    shape: Shape = FlatShape()
    polygon: Ring | None = None
    center: XY | None = None
    radius: NonNeg | None = None
    frame: Literal["world"] = "world"

    @model_validator(mode="after")
    def _one_footprint(self) -> "MapObject":
        if (self.polygon is None) == (self.center is None):
            raise ValueError("give exactly one of polygon or center (+ radius)")
        if self.center is not None and self.radius is None:
            raise ValueError("a round (center) object needs a radius [m]")
        return self

    @property
    def traversable(self) -> bool:
        """Return whether the object can be driven on (has a finite cost)."""
        return self.cost is not None


@token_type("map_places")
class MapPlaces(Frozen):
    """The destinations the MAP NAVIGATOR can route to by name: the place names and path node ids of map `map_name`."""

    map_name: str
    places: tuple[str, ...]
    nodes: tuple[str, ...] = ()

    def knows(self, name: str) -> bool:
        """Return whether a step may name `name` as its destination."""
        return name in self.places or name in self.nodes
