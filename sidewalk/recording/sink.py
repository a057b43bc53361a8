"""The MCAP file of a recording: JSON channels registered as they first appear, sim-time stamps.

`log_time` is the sim time [ns] at which the recorder received a message (never before the
message's own stamp, never before the previous message of its channel, so each channel is in
order); `publish_time` is the message's own sim stamp where it carries one. Sim time counts from
the simulator's start, so the file's epoch is the run's t = 0. Used from one thread only.
"""

from __future__ import annotations

import base64
import json
from collections import Counter
from pathlib import Path
from typing import Any

from mcap.writer import CompressionType, Writer

from sidewalk.recording.channels import jsonable
from sidewalk.recording.errors import RecordingError
from sidewalk.recording.schemas import schema_bytes

__all__ = ["McapSink", "to_json_bytes", "PROFILE"]

#: The MCAP profile written in the header (none of the well-known ones: plain JSON channels).
PROFILE = ""


def _default(o: Any) -> Any:
    if isinstance(o, (bytes, bytearray, memoryview)):
        return base64.b64encode(bytes(o)).decode()
    if hasattr(o, "model_dump"):
        return o.model_dump(mode="json")
    raise TypeError(f"cannot record a {type(o).__name__}")


def to_json_bytes(obj: Any) -> bytes:
    """Return compact JSON of `obj` (bytes as base64, NaN/inf as null); a non-object is wrapped as {"payload": obj}."""
    if not isinstance(obj, dict):
        obj = {"payload": obj}
    try:
        return json.dumps(obj, separators=(",", ":"), allow_nan=False, default=_default).encode()
    except ValueError:  # a NaN or an infinity somewhere: the slow path
        return json.dumps(jsonable(obj), separators=(",", ":"), allow_nan=False, default=_default).encode()


class McapSink:
    """Write JSON messages to an MCAP file; channels and schemas are registered on first use."""

    def __init__(self, path: Path, *, chunk_size: int = 256 * 1024, metadata: dict[str, str] | None = None) -> None:
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._f = open(self.path, "wb")
        except OSError as exc:
            raise RecordingError(f"cannot write the recording {self.path}: {exc.strerror or exc}") from None
        self._w = Writer(self._f, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._w.start(profile=PROFILE, library="sidewalk-recorder")
        if metadata:
            self._w.add_metadata("sidewalk", {k: str(v) for k, v in metadata.items()})
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._last: dict[int, int] = {}
        self._seq: Counter[int] = Counter()
        #: messages written per topic
        self.counts: Counter[str] = Counter()
        self.bytes_in = 0
        self._closed = False

    def channel(self, topic: str, schema_name: str, schema: dict | None, *, metadata: dict[str, str] | None = None) -> int:
        """Return the channel id of `topic`, registering it (and its schema) the first time."""
        cid = self._channels.get(topic)
        if cid is not None:
            return cid
        sid = self._schemas.get(schema_name)
        if sid is None:
            sid = self._w.register_schema(name=schema_name, encoding="jsonschema", data=schema_bytes(schema or {"type": "object"}))
            self._schemas[schema_name] = sid
        cid = self._w.register_channel(topic=topic, message_encoding="json", schema_id=sid, metadata=metadata or {})
        self._channels[topic] = cid
        return cid

    def has(self, topic: str) -> bool:
        """Return whether `topic` has a channel yet."""
        return topic in self._channels

    def write(self, cid: int, topic: str, log_s: float, obj: Any, *, publish_s: float | None = None) -> float:
        """Write `obj` as JSON on channel `cid` received at sim time `log_s` [s]; return the log time used [s]."""
        log_ns = max(0, int(round(log_s * 1e9)))
        prev = self._last.get(cid)
        if prev is not None and log_ns < prev:
            log_ns = prev
        pub_ns = log_ns if publish_s is None else max(0, int(round(publish_s * 1e9)))
        data = obj if isinstance(obj, bytes) else to_json_bytes(obj)
        self._seq[cid] += 1
        self._w.add_message(channel_id=cid, log_time=log_ns, data=data, publish_time=pub_ns, sequence=self._seq[cid])
        self._last[cid] = log_ns
        self.counts[topic] += 1
        self.bytes_in += len(data)
        return log_ns / 1e9

    @property
    def closed(self) -> bool:
        """Return whether the file has been finished."""
        return self._closed

    def close(self) -> None:
        """Write the summary and indexes and close the file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._w.finish()
        finally:
            self._f.close()
