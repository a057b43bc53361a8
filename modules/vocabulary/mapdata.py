"""Map objects: the OBJECT DATA BASE entries the MAP NAVIGATOR copies into route segments.

Geometry is in the `world` frame (x east, y north) [m]. Mirrors the world/map GeoJSON schema.
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field, model_validator

from blackboard.registry import token_type
from modules.vocabulary._base import XY, Frozen, NonNeg, Ring, finite

__all__ = [
    "ObjectRole", "ColourStats", "FlatShape", "SlopeShape", "StairsShape", "PrismShape",
    "TreeShape", "PostShape", "Shape", "MapObject",
]

#: Role of an object in navigation (seed §2.3.7).
ObjectRole = Literal["path", "landmark", "obstacle", "none"]

_RGB = tuple[
    Annotated[float, Field(ge=0.0, le=255.0)],
    Annotated[float, Field(ge=0.0, le=255.0)],
    Annotated[float, Field(ge=0.0, le=255.0)],
]
_RGBStd = tuple[NonNeg, NonNeg, NonNeg]


class ColourStats(Frozen):
    """Gaussian colour statistics of a surface: sRGB mean and std under full sun [0–255]."""

    mean: _RGB
    std: _RGBStd


class FlatShape(Frozen):
    """A horizontal surface at height z [m]."""

    type: Literal["flat"] = "flat"
    z: finite = 0.0


class SlopeShape(Frozen):
    """A plane rising `rise` [m] across the polygon along math angle axis_deg [deg] CCW from +x."""

    type: Literal["slope"] = "slope"
    z0: finite = 0.0
    rise: finite
    axis_deg: finite


class StairsShape(Frozen):
    """Stairs rising `rise` [m] along axis_deg [deg] in steps of step_rise [m]."""

    type: Literal["stairs"] = "stairs"
    z0: finite = 0.0
    rise: finite
    axis_deg: finite
    step_rise: Annotated[float, Field(gt=0.0)]


class PrismShape(Frozen):
    """A vertical prism (building, hedge) of height [m] over the outline, standing at z0 [m]."""

    type: Literal["prism"] = "prism"
    height: Annotated[float, Field(gt=0.0)]
    z0: finite = 0.0


class TreeShape(Frozen):
    """A tree: trunk radius, crown radius [m], total height and crown base height [m], base z0 [m], crown colour."""

    type: Literal["tree"] = "tree"
    trunk_radius: Annotated[float, Field(gt=0.0)]
    crown_radius: Annotated[float, Field(gt=0.0)]
    height: Annotated[float, Field(gt=0.0)]
    crown_base: NonNeg
    z0: finite = 0.0
    crown_colour: ColourStats | None = None


class PostShape(Frozen):
    """A post (lamp post, mailbox) of height [m] on the object's round footprint, standing at z0 [m]."""

    type: Literal["post"] = "post"
    height: Annotated[float, Field(gt=0.0)]
    z0: finite = 0.0


#: The 3-D shape of an object, discriminated by `type`.
Shape = Annotated[
    Union[FlatShape, SlopeShape, StairsShape, PrismShape, TreeShape, PostShape],
    Field(discriminator="type"),
]


@token_type("map_object")
class MapObject(Frozen):
    """One object of the map (world frame): polygon or center+radius, role, cost, colour, 3-D shape.

    Mirrors `vehicle_sim.worldfile.WorldObject`. `cost` is the traversal cost multiplier per metre;
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
