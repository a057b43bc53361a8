"""The Foxglove message schemas a recording uses, as frozen pydantic models, and their JSON schemas.

Foxglove Studio (and Rerun) recognise a JSON channel by its schema *name* (`foxglove.FrameTransform`,
`foxglove.SceneUpdate`, `foxglove.CompressedImage`, `foxglove.GeoJSON`); the field names and shapes here follow
Foxglove's published schemas (docs.foxglove.dev, "Message schemas"). Times are `{sec, nsec}` of sim
time since the simulator started; lengths [m]; frames are Sidewalk's (`world`, `local`, `vehicle`,
and `vehicle_truth` for the true pose, which must not share `vehicle`'s parent chain).
"""

from __future__ import annotations

import base64
import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "Time", "Duration", "Vector3", "Quaternion", "Pose", "Point3", "Color", "KeyValuePair",
    "FrameTransform", "LinePrimitive", "TextPrimitive", "SpherePrimitive", "SceneEntity", "SceneEntityDeletion",
    "SceneUpdate", "CompressedImage", "GeoJSON", "FOXGLOVE_MODELS", "foxglove_schema", "inline_refs",
    "LINE_STRIP", "LINE_LOOP", "LINE_LIST", "yaw_quaternion", "frame_transform", "line", "rgba",
]

_F = ConfigDict(frozen=True, extra="forbid")

#: LinePrimitive types.
LINE_STRIP, LINE_LOOP, LINE_LIST = 0, 1, 2


class Time(BaseModel):
    """A time stamp: whole seconds and nanoseconds [s, ns] of sim time."""

    model_config = _F
    sec: int = Field(ge=0)
    nsec: int = Field(ge=0, le=999_999_999)

    @classmethod
    def of(cls, t: float) -> "Time":
        """Return the stamp of sim time `t` [s] (negative times clamp to 0)."""
        ns = max(0, int(round(t * 1e9)))
        return cls.model_construct(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


class Duration(BaseModel):
    """A duration [s, ns]; zero means for ever (an entity stays until replaced or deleted)."""

    model_config = _F
    sec: int = 0
    nsec: int = Field(default=0, ge=0, le=999_999_999)


class Vector3(BaseModel):
    """A 3-D vector [m]."""

    model_config = _F
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


class Quaternion(BaseModel):
    """A rotation as a unit quaternion (x, y, z, w)."""

    model_config = _F
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


class Pose(BaseModel):
    """A position [m] and orientation in the entity's frame."""

    model_config = _F
    position: Vector3 = Vector3()
    orientation: Quaternion = Quaternion()


class Point3(BaseModel):
    """A point [m]."""

    model_config = _F
    x: float
    y: float
    z: float = 0.0


class Color(BaseModel):
    """An RGBA colour, each channel in [0, 1]."""

    model_config = _F
    r: float = Field(ge=0.0, le=1.0)
    g: float = Field(ge=0.0, le=1.0)
    b: float = Field(ge=0.0, le=1.0)
    a: float = Field(default=1.0, ge=0.0, le=1.0)


class KeyValuePair(BaseModel):
    """A metadata entry."""

    model_config = _F
    key: str
    value: str


class FrameTransform(BaseModel):
    """`child_frame_id` in `parent_frame_id` at `timestamp`: translation [m] and rotation."""

    model_config = _F
    timestamp: Time
    parent_frame_id: str
    child_frame_id: str
    translation: Vector3
    rotation: Quaternion


class LinePrimitive(BaseModel):
    """Points [m] joined by lines: strip (0), loop (1) or list (2); thickness [m] unless scale invariant [px]."""

    model_config = _F
    type: Literal[0, 1, 2]
    pose: Pose = Pose()
    thickness: float = 0.1
    scale_invariant: bool = False
    points: tuple[Point3, ...]
    color: Color
    colors: tuple[Color, ...] = ()
    indices: tuple[int, ...] = ()


class TextPrimitive(BaseModel):
    """A text label at `pose`; `font_size` [m] unless scale invariant [px]."""

    model_config = _F
    pose: Pose
    billboard: bool = True
    font_size: float = 12.0
    scale_invariant: bool = True
    color: Color
    text: str


class SpherePrimitive(BaseModel):
    """A sphere or ellipsoid at `pose` with diameters `size` [m]."""

    model_config = _F
    pose: Pose
    size: Vector3
    color: Color


class SceneEntity(BaseModel):
    """A visual element in `frame_id`; replaces any earlier entity with the same `id` on its topic.

    Every primitive list is present (empty when unused) so any reader finds the fields it expects.
    """

    model_config = _F
    timestamp: Time
    frame_id: str
    id: str
    lifetime: Duration = Duration()
    frame_locked: bool = False
    metadata: tuple[KeyValuePair, ...] = ()
    arrows: tuple[dict, ...] = ()
    cubes: tuple[dict, ...] = ()
    spheres: tuple[SpherePrimitive, ...] = ()
    cylinders: tuple[dict, ...] = ()
    lines: tuple[LinePrimitive, ...] = ()
    triangles: tuple[dict, ...] = ()
    texts: tuple[TextPrimitive, ...] = ()
    models: tuple[dict, ...] = ()


class SceneEntityDeletion(BaseModel):
    """Remove the entity `id` (type 0) or every entity of the topic (type 1) older than `timestamp`."""

    model_config = _F
    timestamp: Time
    type: Literal[0, 1]
    id: str = ""


class SceneUpdate(BaseModel):
    """Deletions, then new or replaced entities, of a 3-D scene topic."""

    model_config = _F
    deletions: tuple[SceneEntityDeletion, ...] = ()
    entities: tuple[SceneEntity, ...] = ()


class CompressedImage(BaseModel):
    """A JPEG/PNG image: `data` is the base64 text of the encoded bytes (JSON channels carry bytes so)."""

    model_config = _F
    timestamp: Time
    frame_id: str
    data: str = Field(json_schema_extra={"contentEncoding": "base64"})
    format: str

    @classmethod
    def of(cls, t: float, frame_id: str, data: bytes, fmt: str) -> "CompressedImage":
        """Return the image of encoded bytes `data` ("jpeg" or "png") at sim time `t` [s]."""
        return cls(timestamp=Time.of(t), frame_id=frame_id, data=base64.b64encode(data).decode(), format=fmt)


class GeoJSON(BaseModel):
    """A GeoJSON FeatureCollection as text, in WGS84 longitude/latitude [deg] (Foxglove's Map panel draws it)."""

    model_config = _F
    geojson: str


#: Schema name → model of every Foxglove message a recording writes.
FOXGLOVE_MODELS: dict[str, type[BaseModel]] = {
    "foxglove.FrameTransform": FrameTransform,
    "foxglove.SceneUpdate": SceneUpdate,
    "foxglove.CompressedImage": CompressedImage,
    "foxglove.GeoJSON": GeoJSON,
}


def inline_refs(schema: dict) -> dict:
    """Return a JSON schema with every local `$ref` replaced by its definition and `$defs` removed.

    Readers of JSON-schema channels (Foxglove's among them) do not all resolve references.
    """
    defs = schema.get("$defs", {})

    def walk(node: Any, depth: int) -> Any:
        if depth > 40:
            raise ValueError("schema nests too deep (a recursive model?)")
        if isinstance(node, dict):
            if "$ref" in node and node["$ref"].startswith("#/$defs/"):
                target = walk(defs[node["$ref"].split("/")[-1]], depth + 1)
                rest = {k: walk(v, depth + 1) for k, v in node.items() if k != "$ref"}
                return {**target, **rest}
            return {k: walk(v, depth + 1) for k, v in node.items() if k != "$defs"}
        if isinstance(node, list):
            return [walk(v, depth + 1) for v in node]
        return node

    return walk(schema, 0)


def foxglove_schema(name: str) -> dict:
    """Return the self-contained JSON schema of Foxglove message `name` (e.g. "foxglove.FrameTransform")."""
    model = FOXGLOVE_MODELS[name]
    s = inline_refs(model.model_json_schema(mode="serialization"))
    s["title"] = name
    return s


# ---- builders ---------------------------------------------------------------------------------

def yaw_quaternion(yaw: float) -> Quaternion:
    """Return the rotation by `yaw` [rad] about +z."""
    return Quaternion.model_construct(x=0.0, y=0.0, z=math.sin(0.5 * yaw), w=math.cos(0.5 * yaw))


def frame_transform(t: float, parent: str, child: str, x: float, y: float, yaw: float, z: float = 0.0) -> FrameTransform:
    """Return `child` in `parent` at sim time `t` [s]: position (x, y, z) [m], heading `yaw` [rad]."""
    return FrameTransform.model_construct(
        timestamp=Time.of(t), parent_frame_id=parent, child_frame_id=child,
        translation=Vector3.model_construct(x=float(x), y=float(y), z=float(z)), rotation=yaw_quaternion(float(yaw)),
    )


def rgba(r: float, g: float, b: float, a: float = 1.0) -> Color:
    """Return a colour with channels in [0, 1]."""
    return Color.model_construct(r=r, g=g, b=b, a=a)


def line(points: Any, color: Color, *, loop: bool = False, thickness: float = 0.1, z: float = 0.0) -> LinePrimitive:
    """Return a line strip (or closed loop) through (x, y) points [m] at height `z` [m]."""
    pts = tuple(Point3.model_construct(x=float(p[0]), y=float(p[1]), z=z) for p in points)
    return LinePrimitive(type=LINE_LOOP if loop else LINE_STRIP, points=pts, color=color, thickness=thickness)
