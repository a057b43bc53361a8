"""The token: one typed, stamped, located fact on the blackboard."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict

from blackboard.geometry import Geometry, Point, Polygon, Polyline

__all__ = ["Token", "MonitorEvent", "token_from_wire", "token_from_owned_wire", "make_token"]


class Token(BaseModel):
    """A token: node-assigned `id`, `type`, `version` (1 on post), sim-time `stamp` [s], `source`,
    `frame` its geometry is in, optional `geometry` [m], and `attrs` (the typed attribute model)."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    id: str
    type: str
    version: int
    stamp: float
    source: str
    frame: str
    geometry: Geometry | None = None
    attrs: Any = None


class MonitorEvent(BaseModel):
    """A change seen by a monitor: `kind` is new, updated or deleted; `token` the token after it
    (for deleted: the last state)."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    kind: Literal["new", "updated", "deleted"]
    token: Token


# the setters of BaseModel's four slots, called directly (a third cheaper than object.__setattr__ by name)
_set_dict, _set_fields_set, _set_extra, _set_private = (
    BaseModel.__dict__[k].__set__ for k in ("__dict__", "__pydantic_fields_set__", "__pydantic_extra__", "__pydantic_private__"))


def _trusted(cls: type, fields: dict, fields_set: set) -> Any:
    """Build a pydantic model instance from already-valid fields (what model_construct does, minus its overhead)."""
    obj = cls.__new__(cls)
    _set_dict(obj, fields)
    _set_fields_set(obj, fields_set)
    _set_extra(obj, None)
    _set_private(obj, None)
    return obj


_POINT_FIELDS = {"kind", "x", "y"}
_PTS_FIELDS = {"kind", "points"}
_TOKEN_FIELDS = set(Token.model_fields)


def _geom_from_wire(g: dict | None) -> Point | Polyline | Polygon | None:
    if g is None:
        return None
    kind = g["kind"]
    if kind == "point":
        x, y = g["x"], g["y"]
        return _trusted(Point, {"kind": "point", "x": x if type(x) is float else float(x), "y": y if type(y) is float else float(y)},
                        _POINT_FIELDS)
    pts = tuple((float(p[0]), float(p[1])) for p in g["points"])
    if kind == "polyline":
        return _trusted(Polyline, {"kind": "polyline", "points": pts}, _PTS_FIELDS)
    return _trusted(Polygon, {"kind": "polygon", "points": pts}, _PTS_FIELDS)


def token_from_wire(d: dict, attrs: Any) -> Token:
    """Build a Token from its wire dict (trusted: sent by the node) and already-decoded attrs."""
    return _trusted(
        Token,
        {
            "id": d["id"],
            "type": d["type"],
            "version": d["version"],
            "stamp": d["stamp"],
            "source": d["source"],
            "frame": d["frame"],
            "geometry": _geom_from_wire(d.get("geometry")),
            "attrs": attrs,
        },
        _TOKEN_FIELDS,
    )


def token_from_owned_wire(d: dict, attrs: Any) -> Token:
    """Like `token_from_wire`, for a wire dict nobody else holds (just decoded): it becomes the token's fields."""
    if d.keys() != _TOKEN_FIELDS:
        return token_from_wire(d, attrs)
    d["geometry"] = _geom_from_wire(d["geometry"])
    d["attrs"] = attrs
    return _trusted(Token, d, _TOKEN_FIELDS)


def make_token(id: str, type: str, version: int, stamp: float, source: str, frame: str, geometry: Any, attrs: Any) -> Token:
    """Build a Token from trusted fields without validation."""
    return _trusted(
        Token,
        {"id": id, "type": type, "version": version, "stamp": stamp, "source": source, "frame": frame, "geometry": geometry, "attrs": attrs},
        _TOKEN_FIELDS,
    )
