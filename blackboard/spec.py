"""Retrieval specifications: type, attribute predicates, one geometric predicate, any_of, newest, limit.

A token matches a Spec when its type is `type` (if given), every `where` predicate holds, the
`geometry` predicate holds (evaluated in the predicate's frame), and — if `any_of` is not empty —
at least one sub-spec matches. Then `nearest` keeps the k closest, `newest` keeps only the match
with the largest stamp, `limit` keeps the first n.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from blackboard.errors import BadSpecError
from blackboard.geometry import Geometry, Point, Polygon, positional_init

__all__ = [
    "AttrPredicate",
    "Within",
    "Intersects",
    "Near",
    "Nearest",
    "GeoPredicate",
    "Spec",
    "parse_spec",
    "ATTR_OPS",
]

ATTR_OPS = ("==", "!=", "<", "<=", ">", ">=", "in", "exists")
_FRAME = Annotated[str, Field(min_length=1, max_length=128, pattern=r"^[A-Za-z0-9_.\-]+$")]


class AttrPredicate(BaseModel):
    """`attrs.<path> <op> value`; `path` is dotted (list indices as numbers); `exists` tests presence
    (value False: absence)."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    path: str = Field(min_length=1, max_length=256)
    op: Literal["==", "!=", "<", "<=", ">", ">=", "in", "exists"]
    value: Any = True

    @model_validator(mode="after")
    def _check(self) -> "AttrPredicate":
        if self.op == "in" and not isinstance(self.value, (list, tuple)):
            raise ValueError("'in' needs a list value")
        if self.op == "exists" and not isinstance(self.value, bool):
            raise ValueError("'exists' needs a boolean value (or none)")
        if any(not part for part in self.path.split(".")):
            raise ValueError(f"path {self.path!r} has an empty component")
        return self


class _GeoBase(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
    #: Frame the predicate's geometry is stated in.
    frame: _FRAME = "world"
    #: Time [s] of that frame (for moving frames); None = the newest time the pose history answers.
    stamp: float | None = Field(None, allow_inf_nan=False)


class Within(_GeoBase):
    """Token geometry lies inside `polygon` (stated in `frame`)."""

    op: Literal["within"] = "within"
    polygon: Polygon

    @positional_init
    def __init__(self, polygon: Polygon | None = None, frame: str | None = None, /, **kw: Any) -> None:
        if polygon is not None:
            kw["polygon"] = polygon
        if frame is not None:
            kw["frame"] = frame
        super().__init__(**kw)


class Intersects(_GeoBase):
    """Token geometry intersects `geometry` (stated in `frame`)."""

    op: Literal["intersects"] = "intersects"
    geometry: Geometry

    @positional_init
    def __init__(self, geometry: Any = None, frame: str | None = None, /, **kw: Any) -> None:
        if geometry is not None:
            kw["geometry"] = geometry
        if frame is not None:
            kw["frame"] = frame
        super().__init__(**kw)


class Near(_GeoBase):
    """Token geometry is within `distance` [m] of `geometry` (stated in `frame`)."""

    op: Literal["near"] = "near"
    geometry: Geometry
    distance: float = Field(ge=0.0, allow_inf_nan=False)

    @positional_init
    def __init__(self, geometry: Any = None, distance: float | None = None, frame: str | None = None, /, **kw: Any) -> None:
        if geometry is not None:
            kw["geometry"] = geometry
        if distance is not None:
            kw["distance"] = distance
        if frame is not None:
            kw["frame"] = frame
        super().__init__(**kw)


class Nearest(_GeoBase):
    """The `k` tokens whose geometry is closest to `point` (stated in `frame`)."""

    op: Literal["nearest"] = "nearest"
    point: Point
    k: int = Field(1, ge=1, le=100_000)

    @positional_init
    def __init__(self, point: Point | None = None, k: int | None = None, frame: str | None = None, /, **kw: Any) -> None:
        if point is not None:
            kw["point"] = point
        if k is not None:
            kw["k"] = k
        if frame is not None:
            kw["frame"] = frame
        super().__init__(**kw)


GeoPredicate = Annotated[Union[Within, Intersects, Near, Nearest], Field(discriminator="op")]


class Spec(BaseModel):
    """A retrieval specification (see module docstring for the semantics)."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    type: str | None = Field(None, min_length=1, max_length=128)
    where: tuple[AttrPredicate, ...] = ()
    geometry: GeoPredicate | None = None
    any_of: tuple["Spec", ...] = ()
    newest: bool = False
    limit: int | None = Field(None, ge=1, le=1_000_000)

    @field_validator("any_of")
    @classmethod
    def _depth(cls, v: tuple["Spec", ...]) -> tuple["Spec", ...]:
        if len(v) > 64:
            raise ValueError("any_of takes at most 64 sub-specs")
        return v

    def frames(self) -> set[str]:
        """Return every frame a geometric predicate in this spec (or its sub-specs) is stated in."""
        out = {self.geometry.frame} if self.geometry is not None else set()
        for s in self.any_of:
            out |= s.frames()
        return out

    def is_set_level(self) -> bool:
        """Return True if matching depends on the other tokens (nearest, newest, limit)."""
        if self.newest or self.limit is not None or isinstance(self.geometry, Nearest):
            return True
        return any(s.is_set_level() for s in self.any_of)

    def types(self) -> set[str] | None:
        """Return the token types this spec can match, or None for any type."""
        if self.type is not None:
            return {self.type}
        if not self.any_of:
            return None
        out: set[str] = set()
        for s in self.any_of:
            t = s.types()
            if t is None:
                return None
            out |= t
        return out


def parse_spec(obj: object) -> Spec:
    """Validate a wire spec dict; raise BadSpecError saying where and what."""
    if isinstance(obj, Spec):
        return obj
    if not isinstance(obj, dict):
        raise BadSpecError(f"spec must be an object, got {type(obj).__name__}")
    try:
        return Spec.model_validate(obj)
    except ValidationError as exc:
        parts = []
        for e in exc.errors()[:5]:
            loc = ".".join(str(p) for p in e.get("loc", ())) or "(root)"
            parts.append(f"{loc}: {e.get('msg')}")
        raise BadSpecError("bad spec: " + "; ".join(parts)) from None
    except (TypeError, ValueError, RecursionError) as exc:
        raise BadSpecError(f"bad spec: {exc}"[:500]) from None
