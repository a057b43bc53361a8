"""JSON schemas of a recording's channels: derived from the pydantic model of a message where one exists.

Every schema is self-contained (references inlined) and describes the JSON the recorder writes:
bytes travel as base64 text (`contentEncoding: base64`), a payload that is not a JSON object is
wrapped as `{"payload": …}` (schema `sidewalk.Raw`), and blackboard token events as
`{"event", "token": {id, type, version, stamp, source, frame, geometry, attrs}}` with `attrs`
described by the token type's model.
"""

from __future__ import annotations

import json
from typing import Any

from pydantic import BaseModel

from sidewalk.recording.foxglove import inline_refs

__all__ = ["model_schema", "token_schema", "RAW_SCHEMA", "ALIVE_SCHEMA", "schema_bytes", "GEOMETRY_SCHEMA"]

#: A payload without a model: any JSON object, or any value wrapped as {"payload": value}.
RAW_SCHEMA: dict = {
    "title": "sidewalk.Raw",
    "description": "A message without a model of its own: a JSON object as published, or {payload: value} "
                   "for a list or scalar (msgpack decoded; bytes as base64 text)",
    "type": "object",
}

#: A liveliness change: the token's key and whether it appeared (true) or went (false).
ALIVE_SCHEMA: dict = {
    "title": "sidewalk.Liveliness",
    "type": "object",
    "properties": {"key": {"type": "string"}, "name": {"type": "string"}, "alive": {"type": "boolean"}},
    "required": ["key", "name", "alive"],
}

#: A token's geometry on the wire ([m], in the token's frame), or null.
GEOMETRY_SCHEMA: dict = {
    "anyOf": [
        {"type": "null"},
        {"type": "object", "properties": {"kind": {"const": "point"}, "x": {"type": "number"}, "y": {"type": "number"}},
         "required": ["kind", "x", "y"]},
        {"type": "object", "properties": {
            "kind": {"enum": ["polyline", "polygon"]},
            "points": {"type": "array", "items": {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2}},
        }, "required": ["kind", "points"]},
    ],
}


def _bytes_as_base64(node: Any) -> Any:
    """Rewrite pydantic's bytes schemas (`format: binary`) to base64 text, as the recorder writes bytes."""
    if isinstance(node, dict):
        out = {k: _bytes_as_base64(v) for k, v in node.items()}
        if out.get("type") == "string" and out.get("format") in ("binary", "base64"):
            out.pop("format")
            out["contentEncoding"] = "base64"
        return out
    if isinstance(node, list):
        return [_bytes_as_base64(v) for v in node]
    return node


def model_schema(model: type[BaseModel], name: str) -> dict:
    """Return the self-contained JSON schema of `model`'s serialised form, titled `name`."""
    s = _bytes_as_base64(inline_refs(model.model_json_schema(mode="serialization")))
    s["title"] = name
    return s


def token_schema(type_name: str, model: type[BaseModel] | None) -> dict:
    """Return the schema of a blackboard token event of type `type_name` (attrs from `model`, if known)."""
    attrs = inline_refs(model.model_json_schema(mode="serialization")) if model is not None else {"type": "object"}
    attrs.pop("title", None)
    return {
        "title": f"sidewalk.token.{type_name}",
        "description": f"A blackboard event of a `{type_name}` token: new, updated, deleted (its last state), "
                       "or present (already there when the recorder started)",
        "type": "object",
        "properties": {
            "event": {"enum": ["new", "updated", "deleted", "present"]},
            "token": {
                "type": "object",
                "properties": {
                    "id": {"type": "string"},
                    "type": {"const": type_name},
                    "version": {"type": "integer", "minimum": 1},
                    "stamp": {"type": "number", "description": "sim time [s]"},
                    "source": {"type": "string"},
                    "frame": {"type": "string"},
                    "geometry": GEOMETRY_SCHEMA,
                    "attrs": attrs,
                },
                "required": ["id", "type", "version", "stamp", "frame", "attrs"],
            },
        },
        "required": ["event", "token"],
    }


def schema_bytes(schema: dict) -> bytes:
    """Return the schema as compact UTF-8 JSON (what an MCAP schema record holds)."""
    return json.dumps(schema, separators=(",", ":"), sort_keys=True).encode()
