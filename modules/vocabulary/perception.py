"""Perception vocabulary: detected objects, position fixes and the perception result of a driving unit.

Seed §2.3.5, §3: per driving unit PERCEPTION reports the detected objects, the navigable passage and,
when the scene allows, a position fix: a full pose with covariance, or only a line (a straight
sidewalk tells the distance from its edge and the heading, not the position along it).
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field, model_validator

from modules.vocabulary._base import XY, Cov3, Frozen, NonNeg, Pose, Ring, finite, token_type

__all__ = [
    "SurfaceType", "SensorMode", "ResultFrame", "DetectedObject", "PointFix", "LineFix", "PositionFix",
    "PerceptionResult",
]

#: Surface type of a patch from range segmentation.
SurfaceType = Literal["flat", "slope", "stairs", "rough", "vertical", "unknown"]
#: Which sensors and segmentation produced a result.
SensorMode = Literal["colour", "range", "colored-range"]
#: Frame of the coordinates in a perception result: world, local, or the vehicle frame at capture.
ResultFrame = Literal["world", "local", "vehicle"]

_RGB = tuple[
    Annotated[float, Field(ge=0.0, le=255.0)],
    Annotated[float, Field(ge=0.0, le=255.0)],
    Annotated[float, Field(ge=0.0, le=255.0)],
]


class DetectedObject(Frozen):
    """An object found in the scene: its outline, the map object it matched (if any), its surface."""

    object_id: str | None = None
    kind: str
    outline: Ring
    surface: SurfaceType = "unknown"
    colour_mean: _RGB | None = None
    normal: tuple[finite, finite, finite] | None = None
    confidence: Annotated[float, Field(ge=0.0, le=1.0)] = 1.0


class PointFix(Frozen):
    """A full vehicle pose fix in the world frame at capture time, with its covariance."""

    kind: Literal["point"] = "point"
    pose: Pose
    covariance: Cov3


class LineFix(Frozen):
    """A partial fix: the vehicle lies on the line through `point` along `direction` [rad] (world).

    `lateral_var` [m²] is the variance across the line; `yaw` [rad] with `yaw_var` [rad²] is the
    heading when the scene gives it (parallel edges do).
    """

    kind: Literal["line"] = "line"
    point: XY
    direction: finite
    lateral_var: NonNeg
    yaw: finite | None = None
    yaw_var: NonNeg | None = None

    @model_validator(mode="after")
    def _yaw_pair(self) -> "LineFix":
        if (self.yaw is None) != (self.yaw_var is None):
            raise ValueError("give yaw and yaw_var together, or neither")
        return self


#: A position fix from PERCEPTION: point (full pose) or line, discriminated by `kind`.
PositionFix = Annotated[Union[PointFix, LineFix], Field(discriminator="kind")]


@token_type("perception_result")
class PerceptionResult(Frozen):
    """What PERCEPTION saw for one driving unit: status, detected objects, navigable region, fix.

    Written back into the driving unit description (`DrivingUnitDescription.result`) and also
    postable on its own. Coordinates are in `frame` (the vehicle frame means the vehicle at
    `captured_at`); `captured_at` is the image input time [s] sim; `processing_s` is wall time [s].
    """

    unit_id: str
    segment_id: str
    status: Literal["perceived", "failed"]
    failure_reason: str = ""
    captured_at: finite
    sensor: SensorMode
    frame: ResultFrame = "world"
    view_frame: Ring | None = None
    detected: tuple[DetectedObject, ...] = ()
    navigable_region: Ring | None = None
    fix: PositionFix | None = None
    processing_s: NonNeg = 0.0

    @model_validator(mode="after")
    def _failed_has_reason(self) -> "PerceptionResult":
        if self.status == "failed" and not self.failure_reason:
            raise ValueError("a failed perception result needs a failure_reason")
        return self
