"""Base class and shared value types for every Sidewalk vocabulary model."""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from wire.token_types import declare, declared
from wire.se2 import PoseFields

__all__ = ["Frozen", "XY", "Ring", "Polyline2", "Pose", "Cov3", "finite", "NonNeg", "token_type", "register_token_types"]


class Frozen(BaseModel):
    """Frozen, strict-shape pydantic base for tokens and their parts."""

    model_config = ConfigDict(frozen=True, extra="forbid")


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError(f"must be a finite number, got {v!r}")
    return v


#: A finite float (NaN and ±inf rejected: tokens travel as JSON too).
finite = Annotated[float, AfterValidator(_finite)]
#: A finite float ≥ 0.
NonNeg = Annotated[float, AfterValidator(_finite), Field(ge=0.0)]

#: A 2-D point (x [m], y [m]) in the frame its owner names.
XY = tuple[finite, finite]


def _check_ring(v: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    if len(v) < 3:
        raise ValueError(f"a polygon ring needs at least 3 vertices, got {len(v)}")
    return v


def _check_line(v: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    if len(v) < 2:
        raise ValueError(f"a polyline needs at least 2 vertices, got {len(v)}")
    return v


#: A polygon exterior ring, ≥ 3 vertices (x [m], y [m]), not repeating the first vertex.
Ring = Annotated[tuple[XY, ...], AfterValidator(_check_ring)]
#: A polyline, ≥ 2 vertices (x [m], y [m]).
Polyline2 = Annotated[tuple[XY, ...], AfterValidator(_check_line)]


def _check_cov(v: tuple[float, ...]) -> tuple[float, ...]:
    if len(v) != 9:
        raise ValueError(f"a 3x3 covariance needs 9 row-major entries, got {len(v)}")
    for i in range(3):
        if v[4 * i] < 0.0:
            raise ValueError("covariance diagonal entries must be ≥ 0")
    for i in range(3):
        for j in range(3):
            if abs(v[3 * i + j] - v[3 * j + i]) > 1e-9 * (1.0 + abs(v[3 * i + j])):
                raise ValueError("covariance must be symmetric")
    return v


#: Row-major 3x3 covariance of (x [m], y [m], yaw [rad]): units [m²], [m·rad], [rad²].
Cov3 = Annotated[tuple[finite, ...], AfterValidator(_check_cov)]


class Pose(PoseFields, Frozen):
    """An SE(2) pose: position (x [m], y [m]) and heading yaw [rad] CCW from +x, in a named frame."""

    x: finite
    y: finite
    yaw: finite = 0.0


def token_type(name: str):  # noqa: ANN201 - a decorator returning its argument
    """Declare the decorated model as blackboard token type `name` without importing `blackboard`.

    The declaration goes to `wire.token_types`; the blackboard's default registry follows it (in any
    import order), so EDDIE imports the vocabulary without loading the blackboard.
    """

    def deco(model):  # noqa: ANN001, ANN202
        declare(name, model)
        return model

    return deco


def register_token_types(registry) -> None:  # noqa: ANN001 - a blackboard.TypeRegistry
    """Register every declared token type with `registry` (the default registry follows them by itself)."""
    for name, model in declared().items():
        registry.register(name, model)
