"""2-D geometry carried by tokens and specs (points, polylines, polygons) and SE(2) poses.

Coordinates are metres in the frame the token or predicate names. Wire forms:
``{"kind": "point", "x": x, "y": y}``, ``{"kind": "polyline", "points": [[x, y], ...]}``,
``{"kind": "polygon", "points": [[x, y], ...]}`` (outer ring, not closed, at least 3 vertices).
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Union

import numpy as np
import shapely
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from blackboard.errors import InvalidTokenError
from wire.se2 import Pose2D

__all__ = [
    "Point",
    "Polyline",
    "Polygon",
    "Geometry",
    "Pose2D",
    "geometry_coords",
    "geometry_from_coords",
    "parse_geometry_wire",
    "parse_geometry_wire_fast",
    "coords_to_wire",
    "to_shapely",
    "polygon_shape",
    "positional_init",
]

_XY = tuple[float, float]


def positional_init(init: Any) -> Any:
    """Mark a model's `__init__` that only maps positional arguments to fields as pydantic's own.

    Pydantic calls a custom `__init__` for every nested object it validates, and then runs the
    model's after-validators a second time (measured: a Within spec's polygon checked twice, 35 µs
    of a retrieve's 45 µs of validation). Validating a dict needs no positional mapping, so it can
    skip the `__init__`; a call `Polygon(points)` still goes through it.
    """
    init.__pydantic_base_init__ = True
    return init


def _finite_points(pts: tuple[_XY, ...]) -> tuple[_XY, ...]:
    for p in pts:
        if not (math.isfinite(p[0]) and math.isfinite(p[1])):
            raise ValueError(f"coordinate {p!r} is not finite")
    return pts


class Point(BaseModel):
    """A point (x [m], y [m])."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    kind: Literal["point"] = "point"
    x: float = Field(allow_inf_nan=False)
    y: float = Field(allow_inf_nan=False)

    @positional_init
    def __init__(self, x: float | None = None, y: float | None = None, /, **kw: Any) -> None:
        if x is not None:
            kw["x"] = x
        if y is not None:
            kw["y"] = y
        super().__init__(**kw)


class Polyline(BaseModel):
    """An open polyline of at least two vertices [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    kind: Literal["polyline"] = "polyline"
    points: tuple[_XY, ...]

    @positional_init
    def __init__(self, points: Any = None, /, **kw: Any) -> None:
        if points is not None:
            kw["points"] = points
        super().__init__(**kw)

    @field_validator("points")
    @classmethod
    def _check(cls, v: tuple[_XY, ...]) -> tuple[_XY, ...]:
        if len(v) < 2:
            raise ValueError("a polyline needs at least 2 vertices")
        return _finite_points(v)


class Polygon(BaseModel):
    """A simple polygon: outer ring of at least three vertices [m], not repeated at the end."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    kind: Literal["polygon"] = "polygon"
    points: tuple[_XY, ...]

    @positional_init
    def __init__(self, points: Any = None, /, **kw: Any) -> None:
        if points is not None:
            kw["points"] = points
        super().__init__(**kw)

    @model_validator(mode="after")
    def _check(self) -> "Polygon":
        _finite_points(self.points)
        xy = np.asarray(self.points, dtype=np.float64)
        _remember_shape(self, xy, _check_polygon(xy))
        return self


Geometry = Annotated[Union[Point, Polyline, Polygon], Field(discriminator="kind")]


def _check_polygon(xy: np.ndarray) -> shapely.Polygon:
    """Raise ValueError unless the (N,2) vertices [m] make a simple polygon of positive area; return its shapely polygon."""
    if len(xy) >= 2 and xy[0, 0] == xy[-1, 0] and xy[0, 1] == xy[-1, 1]:  # (np.array_equal costs 2 µs here)
        xy = xy[:-1]
    if len(xy) < 3:
        raise ValueError("a polygon needs at least 3 distinct vertices")
    poly = shapely.Polygon(xy)
    if poly.area <= 0.0:
        raise ValueError("polygon has zero area")
    if not poly.is_valid:
        raise ValueError("polygon is not simple (self-intersecting)")
    return poly


#: the coordinates and shapely polygon of the polygons validated last, by identity (each entry holds its
#: model, so an id is not reused while it is here): a spec's region reuses what its validation built
_shapes: dict[int, tuple[Polygon, np.ndarray, shapely.Polygon]] = {}
_SHAPES_KEPT = 64


def _remember_shape(p: Polygon, xy: np.ndarray, shape: shapely.Polygon) -> None:
    if len(_shapes) >= _SHAPES_KEPT:
        _shapes.clear()
    _shapes[id(p)] = (p, xy, shape)


def polygon_shape(p: Polygon) -> tuple[np.ndarray, shapely.Polygon]:
    """Return a polygon's (N,2) float64 vertices [m] and its shapely polygon (built at validation if that was recent)."""
    hit = _shapes.get(id(p))
    if hit is not None and hit[0] is p:
        return hit[1], hit[2]
    xy = np.asarray(p.points, dtype=np.float64)
    return xy, shapely.Polygon(xy)


def geometry_coords(geom: Point | Polyline | Polygon) -> tuple[str, np.ndarray]:
    """Return (kind, (N,2) float64 coordinates [m]) of a geometry model."""
    if isinstance(geom, Point):
        return "point", np.array([[geom.x, geom.y]], dtype=np.float64)
    return geom.kind, np.asarray(geom.points, dtype=np.float64)


def geometry_from_coords(kind: str, xy: np.ndarray) -> Point | Polyline | Polygon:
    """Return the geometry model of a kind and (N,2) coordinates [m] (no re-validation)."""
    if kind == "point":
        return Point.model_construct(kind="point", x=float(xy[0, 0]), y=float(xy[0, 1]))
    pts = tuple((float(a), float(b)) for a, b in xy.tolist())
    if kind == "polyline":
        return Polyline.model_construct(kind="polyline", points=pts)
    return Polygon.model_construct(kind="polygon", points=pts)


def coords_to_wire(kind: str, xy: np.ndarray) -> dict:
    """Return the wire dict of a kind and (N,2) coordinates [m]."""
    if kind == "point":
        return {"kind": "point", "x": float(xy[0, 0]), "y": float(xy[0, 1])}
    return {"kind": kind, "points": xy.tolist()}


def parse_geometry_wire_fast(obj: object) -> tuple[str, np.ndarray | tuple[float, float]]:
    """Like `parse_geometry_wire`, but a well-formed point with float coordinates comes back as an (x, y) tuple [m]."""
    if type(obj) is dict and len(obj) == 3 and obj.get("kind") == "point":
        x, y = obj.get("x"), obj.get("y")
        if type(x) is float and type(y) is float and math.isfinite(x) and math.isfinite(y):
            return "point", (x, y)
    return parse_geometry_wire(obj)


def parse_geometry_wire(obj: object) -> tuple[str, np.ndarray]:
    """Validate a wire geometry dict; return (kind, (N,2) float64 coords [m]); raise InvalidTokenError."""
    if not isinstance(obj, dict):
        raise InvalidTokenError(f"geometry must be an object with 'kind', got {type(obj).__name__}")
    kind = obj.get("kind")
    try:
        if kind == "point":
            if set(obj) - {"kind", "x", "y"}:
                raise ValueError(f"unexpected fields {sorted(set(obj) - {'kind', 'x', 'y'})}")
            x, y = obj["x"], obj["y"]
            if isinstance(x, bool) or isinstance(y, bool) or isinstance(x, str) or isinstance(y, str):
                raise ValueError("x and y must be numbers")
            fx, fy = float(x), float(y)
            if not (math.isfinite(fx) and math.isfinite(fy)):
                raise ValueError("coordinates must be finite")
            return kind, np.array([[fx, fy]], dtype=np.float64)
        elif kind in ("polyline", "polygon"):
            if set(obj) - {"kind", "points"}:
                raise ValueError(f"unexpected fields {sorted(set(obj) - {'kind', 'points'})}")
            pts = obj["points"]
            if not isinstance(pts, (list, tuple)):
                raise ValueError("points must be a list of [x, y]")
            for p in pts:
                if not isinstance(p, (list, tuple)) or len(p) != 2 or any(isinstance(c, (bool, str, bytes)) for c in p):
                    raise ValueError(f"vertex {p!r} is not [x, y]")
            xy = np.array(pts, dtype=np.float64).reshape(-1, 2)
        else:
            raise ValueError(f"unknown geometry kind {kind!r} (point, polyline, polygon)")
        if not np.isfinite(xy).all():
            raise ValueError("coordinates must be finite")
        if kind == "polyline" and len(xy) < 2:
            raise ValueError("a polyline needs at least 2 vertices")
        if kind == "polygon":
            if len(xy) >= 2 and np.array_equal(xy[0], xy[-1]):
                xy = xy[:-1]
            _check_polygon(xy)
    except InvalidTokenError:
        raise
    except Exception as exc:  # noqa: BLE001 - any malformed input is an invalid token, never a crash
        raise InvalidTokenError(f"invalid geometry: {type(exc).__name__}: {exc}"[:300]) from None
    return kind, xy


def to_shapely(kind: str, xy: np.ndarray) -> shapely.Geometry:
    """Return the shapely geometry of a kind and (N,2) coordinates [m]."""
    if kind == "point":
        return shapely.Point(xy[0])
    if kind == "polyline":
        return shapely.LineString(xy)
    return shapely.Polygon(xy)
