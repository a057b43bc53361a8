"""Which channel a key of the system is recorded on: topic, schema, and where its sim stamp is.

One channel per key (topic = the key below `sidewalk/<ns>`, e.g. `/sim/truth`, `/heartbeat/pilot`);
keys of one family share a schema (every `heartbeat/<name>` is a `sidewalk.Heartbeat`). Payloads are
decoded from msgpack (or JSON) to JSON-ready values by `jsonable`.
"""

from __future__ import annotations

import base64
import json
import math
from dataclasses import dataclass
from typing import Any

import msgpack
from pydantic import BaseModel

from modules.vocabulary import MissionStatus
from sidewalk.recording.schemas import RAW_SCHEMA, model_schema
from wire.drive import DriveCommand, Odometry, SimClock, SimEvent, TruthPose
from wire.health import Heartbeat
from wire.preview import SimPreview

__all__ = ["Family", "family_of", "topic_of", "decode_payload", "jsonable", "FAMILIES"]


@dataclass(frozen=True)
class Family:
    """A family of keys: its schema name and model (None: raw), the field holding the sim stamp [s]."""

    pattern: str
    schema_name: str
    model: type[BaseModel] | None
    stamp_field: str | None

    def schema(self) -> dict:
        """Return the JSON schema of the family's messages."""
        if self.model is None:
            return dict(RAW_SCHEMA, title=self.schema_name)
        return model_schema(self.model, self.schema_name)


#: Families by key below `sidewalk/<ns>/`: exact keys, or prefixes ending in "/".
FAMILIES: tuple[Family, ...] = (
    Family("sim/clock", "sidewalk.SimClock", SimClock, "stamp"),
    Family("sim/odom", "sidewalk.Odometry", Odometry, "stamp"),
    Family("sim/truth", "sidewalk.TruthPose", TruthPose, "stamp"),
    Family("sim/events", "sidewalk.SimEvent", SimEvent, "stamp"),
    Family("sim/cmd", "sidewalk.DriveCommand", DriveCommand, None),
    Family("sim/preview", "sidewalk.SimPreview", SimPreview, "stamp"),
    Family("sim/map", "sidewalk.GeoJSON", None, None),
    Family("sim/world", "sidewalk.GeoJSON", None, None),
    Family("heartbeat/", "sidewalk.Heartbeat", Heartbeat, "sim_time"),
    Family("mission/events", "sidewalk.MissionStatus", MissionStatus, None),
    Family("bb/write/", "sidewalk.bb.WriteBatch", None, None),
    Family("bb/to/", "sidewalk.bb.ClientMessage", None, None),
    Family("eddie/", "sidewalk.eddie.Message", None, "stamp"),
)
_RAW = Family("", "sidewalk.Raw", None, "stamp")


def family_of(rel_key: str) -> Family:
    """Return the family of a key below `sidewalk/<ns>/` (the raw family when none matches)."""
    for f in FAMILIES:
        if rel_key == f.pattern or (f.pattern.endswith("/") and rel_key.startswith(f.pattern)):
            return f
    return _RAW


def topic_of(rel_key: str) -> str:
    """Return the recording topic of a key below `sidewalk/<ns>/`."""
    return "/" + rel_key


def decode_payload(payload: bytes, is_json: bool) -> Any:
    """Return the value in a msgpack or JSON payload (the raw bytes, base64, when neither decodes)."""
    if is_json:
        try:
            return json.loads(payload)
        except ValueError:
            pass
    try:
        return msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except Exception:  # noqa: BLE001 - msgpack raises assorted errors on garbage
        try:
            return json.loads(payload)
        except ValueError:
            return {"undecodable": base64.b64encode(payload).decode()}


def jsonable(v: Any) -> Any:
    """Return `v` as JSON-ready values: bytes → base64 text, non-finite floats → null, map keys → text."""
    if isinstance(v, dict):
        return {k if isinstance(k, str) else str(k): jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [jsonable(x) for x in v]
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, (bytes, bytearray, memoryview)):
        return base64.b64encode(bytes(v)).decode()
    if isinstance(v, BaseModel):
        return v.model_dump(mode="json")
    return v
