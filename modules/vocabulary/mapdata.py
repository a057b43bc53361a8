"""Map objects: the OBJECT DATA BASE entries the MAP NAVIGATOR copies into route segments.

Geometry is in the `world` frame (x east, y north) [m]. Mirrors the world/map GeoJSON schema.
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field, model_validator

from modules.vocabulary._base import token_type
from wire.mapfile import Colour, FlatShape, PostShape, PrismShape, Shape, SlopeShape, StairsShape, TreeShape
from modules.vocabulary._base import XY, Frozen, NonNeg, Ring, finite

__all__ = [
    "ObjectRole", "ColourStats", "FlatShape", "SlopeShape", "StairsShape", "PrismShape",
    "TreeShape", "PostShape", "Shape", "MapObject",
]

#: Role of an object in navigation (seed §2.3.7).
ObjectRole = Literal["path", "landmark", "obstacle", "none"]

#: Gaussian colour statistics of a surface (sRGB mean and std [0–255]); the map-file model itself.
ColourStats = Colour


@token_type("map_object")
class MapObject(Frozen):
    """One object of the map (world frame): polygon or center+radius, role, cost, colour, 3-D shape.

    Copied from `wire.mapfile.WorldObject` (same colour and shape models). `cost` is the traversal cost multiplier per metre;
    None means not traversable. Exactly one of `polygon` (exterior ring [m]) and `center` (with
    `radius` [m]) is given. `reflectance` is the laser reflectance [0–1].
    """

    object_id: str
    kind: str
    role: ObjectRole
    name: str | None = None
    cost: NonNeg | None = None
    colour: ColourStats | None = None
    shape: Shape = FlatShape()
    polygon: Ring | None = None
    center: XY | None = None
    radius: NonNeg | None = None
    reflectance: Annotated[float, Field(ge=0.0, le=1.0)] = 0.5
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
