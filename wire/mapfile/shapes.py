"""The 3-D shape of an object: a flat or sloping ground cover, stairs, a prism, a tree, a post (`Shape`, by `type`)."""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["FlatShape", "SlopeShape", "StairsShape", "PrismShape", "TreeShape", "PostShape", "Shape"]

_FROZEN = ConfigDict(frozen=True, extra="forbid")


class FlatShape(BaseModel):
    """A horizontal surface at height `z` [m]."""

    model_config = _FROZEN
    type: Literal["flat"] = "flat"
    z: float = 0.0


class SlopeShape(BaseModel):
    """A plane rising `rise` [m] across the polygon along math angle `axis_deg` [deg] (CCW from +x) from `z0` [m]."""

    model_config = _FROZEN
    type: Literal["slope"] = "slope"
    z0: float = 0.0
    rise: float
    axis_deg: float


class StairsShape(BaseModel):
    """Steps rising `rise` [m] across the polygon along `axis_deg` [deg] from `z0` [m], `step_rise` [m] each."""

    model_config = _FROZEN
    type: Literal["stairs"] = "stairs"
    z0: float = 0.0
    rise: float = Field(gt=0)
    axis_deg: float
    step_rise: float = Field(gt=0)

    @property
    def n_steps(self) -> int:
        """Return the number of steps (risers)."""
        return max(1, int(round(self.rise / self.step_rise)))


class PrismShape(BaseModel):
    """A vertical extrusion of the footprint, `height` [m] tall, standing at `z0` [m]."""

    model_config = _FROZEN
    type: Literal["prism"] = "prism"
    height: float = Field(gt=0)
    z0: float = 0.0


class TreeShape(BaseModel):
    """A trunk cylinder and a crown sphere-ish ellipsoid: radii [m], total height [m], crown base [m]."""

    model_config = _FROZEN
    type: Literal["tree"] = "tree"
    trunk_radius: float = Field(gt=0)
    crown_radius: float = Field(gt=0)
    height: float = Field(gt=0)
    crown_base: float = Field(ge=0)
    z0: float = 0.0


class PostShape(BaseModel):
    """A vertical cylinder of the footprint radius, `height` [m] tall, standing at `z0` [m]."""

    model_config = _FROZEN
    type: Literal["post"] = "post"
    height: float = Field(gt=0)
    z0: float = 0.0


Shape = Annotated[
    Union[FlatShape, SlopeShape, StairsShape, PrismShape, TreeShape, PostShape],
    Field(discriminator="type"),
]
