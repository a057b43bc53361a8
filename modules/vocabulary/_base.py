"""Base class and shared value types for every Sidewalk vocabulary model."""

from __future__ import annotations

import math
import sys
from typing import Annotated

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

__all__ = ["Frozen", "XY", "Ring", "Polyline2", "Pose", "Cov3", "finite", "NonNeg", "DECLARED_TOKEN_TYPES", "token_type",
           "register_token_types"]


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


class Pose(Frozen):
    """An SE(2) pose: position (x [m], y [m]) and heading yaw [rad] CCW from +x, in a named frame."""

    x: finite
    y: finite
    yaw: finite = 0.0


#: Token type name of every vocabulary model declared so far (bound to the blackboard lazily).
DECLARED_TOKEN_TYPES: dict[str, type[BaseModel]] = {}


def token_type(name: str):  # noqa: ANN201 - a decorator returning its argument
    """Declare the decorated model as blackboard token type `name` without importing `blackboard`.

    The declaration is bound to the blackboard's default registry at once when `blackboard` is
    already loaded (the node's `--types modules.vocabulary`), else by `register_token_types()`
    where a module connects to the blackboard. EDDIE imports the vocabulary without the blackboard.
    """

    def deco(model):  # noqa: ANN001, ANN202
        DECLARED_TOKEN_TYPES[name] = model
        reg = sys.modules.get("blackboard.registry")
        if reg is not None:
            reg.default_registry.register(name, model)
        return model

    return deco


def register_token_types(registry=None) -> None:  # noqa: ANN001 - a blackboard.TypeRegistry
    """Register every declared vocabulary type with `registry` (default: the blackboard's default registry)."""
    if registry is None:
        from blackboard.registry import default_registry as registry  # imported only where tokens are posted
    for name, model in DECLARED_TOKEN_TYPES.items():
        registry.register(name, model)
