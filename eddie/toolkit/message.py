"""EDDIE messages: frozen pydantic models, a registry of message types, and the envelope they travel in.

Every message sent to an inbox or a service travels in an `Envelope` (sender, message type name, sim
stamp [s], body); the registry turns the type name back into its model, so a receiver gets typed
messages. Streams (`publish`) carry the bare model fields (a msgpack map), since a stream has one type
(the NAVIGATION MONITOR reads them so). Wire form: msgpack; JSON accepted when the payload is JSON.
"""

from __future__ import annotations

import json
import math
from typing import Annotated, Any, Callable, TypeVar

import msgpack
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, ValidationError

from eddie.errors import BadMessage, UnknownMessageType

__all__ = [
    "Finite", "Message", "Envelope", "message_type", "message_model", "message_name", "registered_types",
    "encode_envelope", "decode_envelope", "encode_body", "decode_body", "open_envelope",
    "error_payload", "error_text",
]


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError(f"must be a finite number, got {v!r}")
    return v


#: A finite float (NaN and ±inf rejected: messages travel as JSON too).
Finite = Annotated[float, AfterValidator(_finite)]


class Message(BaseModel):
    """Base of every EDDIE message: frozen, no extra fields."""

    model_config = ConfigDict(frozen=True, extra="forbid")


class Envelope(BaseModel):
    """One message on a link: who sent it, its type name, the sender's sim time `stamp` [s], its fields."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    sender: str = Field(min_length=1)
    type: str = Field(min_length=1)
    stamp: float | None = None
    body: dict[str, Any] = Field(default_factory=dict)


M = TypeVar("M", bound=type[Message])
_BY_NAME: dict[str, type[Message]] = {}
_BY_CLASS: dict[type[Message], str] = {}


def message_type(name: str) -> Callable[[M], M]:
    """Register the decorated `Message` model under type name `name` (re-registering the same class is a no-op)."""

    def deco(cls: M) -> M:
        old = _BY_NAME.get(name)
        if old is not None and old.__qualname__ != cls.__qualname__:
            raise ValueError(f"message type {name!r} is already registered to {old.__qualname__}")
        _BY_NAME[name] = cls
        _BY_CLASS[cls] = name
        return cls

    return deco


def message_model(name: str, *, sender: str = "?") -> type[Message]:
    """Return the model registered as `name`; raise UnknownMessageType naming the sender."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise UnknownMessageType(f"message from {sender!r}: unknown message type {name!r}", sender=sender, field="type") from None


def message_name(msg: Message | type[Message]) -> str:
    """Return the registered type name of a message or message class; raise BadMessage when unregistered."""
    cls = msg if isinstance(msg, type) else type(msg)
    try:
        return _BY_CLASS[cls]
    except KeyError:
        raise BadMessage(f"{cls.__qualname__} is not a registered message type (decorate it with @message_type)") from None


def registered_types() -> list[str]:
    """Return every registered message type name, sorted."""
    return sorted(_BY_NAME)


def _load(raw: bytes, what: str, sender: str) -> Any:
    if not raw:
        raise BadMessage(f"{what} from {sender!r}: empty payload", sender=sender)
    try:
        if raw[:1] in (b"{", b"[", b" ", b"\n"):
            return json.loads(raw.decode("utf-8"), parse_constant=lambda c: math.nan)
        return msgpack.unpackb(raw, raw=False, strict_map_key=True)
    except Exception as exc:  # noqa: BLE001 - msgpack/json raise assorted errors on garbage
        raise BadMessage(f"{what} from {sender!r}: payload is neither msgpack nor JSON ({type(exc).__name__})",
                         sender=sender) from None


def _checked(cls: type[BaseModel], data: Any, what: str, sender: str) -> Any:
    try:
        return cls.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        field = ".".join(str(x) for x in e["loc"]) or "<root>"
        raise BadMessage(f"{what} from {sender!r}: field {field}: {e['msg']}", sender=sender, field=field) from None


def _validate(cls: type[Message], data: Any, sender: str) -> Message:
    if not isinstance(data, dict):
        raise BadMessage(f"{cls.__name__} from {sender!r}: body must be a map of fields, got {type(data).__name__}",
                         sender=sender)
    return _checked(cls, data, cls.__name__, sender)


def encode_body(msg: BaseModel, *, as_json: bool = False) -> bytes:
    """Return the bare wire form of a message's fields (msgpack, or JSON)."""
    data = msg.model_dump(mode="json")
    if as_json:
        return json.dumps(data, separators=(",", ":")).encode()
    return msgpack.packb(data, use_bin_type=True)


def decode_body(cls: type[Message], payload: bytes, *, sender: str = "?") -> Message:
    """Return the message of type `cls` in a bare msgpack/JSON payload; raise BadMessage naming sender and field."""
    return _validate(cls, _load(bytes(payload), cls.__name__, sender), sender)


def encode_envelope(sender: str, msg: Message, stamp: float | None, *, as_json: bool = False) -> bytes:
    """Return the wire form of `msg` in an envelope from `sender` stamped `stamp` [s sim]."""
    env = {"sender": sender, "type": message_name(msg), "stamp": stamp, "body": msg.model_dump(mode="json")}
    if as_json:
        return json.dumps(env, separators=(",", ":")).encode()
    return msgpack.packb(env, use_bin_type=True)


def open_envelope(payload: bytes, *, where: str = "inbox") -> Envelope:
    """Return the envelope in a payload (body not yet typed); raise BadMessage saying what is wrong."""
    data = _load(bytes(payload), f"message to {where}", "?")
    if not isinstance(data, dict):
        raise BadMessage(f"message to {where}: an envelope must be a map, got {type(data).__name__}")
    return _checked(Envelope, data, f"envelope of a message to {where}", str(data.get("sender") or "?"))


def decode_envelope(payload: bytes, *, where: str = "inbox") -> tuple[Envelope, Message]:
    """Return (envelope, typed message) of a payload; raise BadMessage naming sender and field."""
    env = open_envelope(payload, where=where)
    cls = message_model(env.type, sender=env.sender)
    return env, _validate(cls, env.body, env.sender)


def error_payload(code: str, message: str) -> bytes:
    """Return the JSON wire form of an error reply: {"error": code, "message": text} (text cut to 500 characters)."""
    return json.dumps({"error": code, "message": message[:500]}).encode()


def error_text(payload: bytes) -> str:
    """Return "code: message" from an error reply (its raw text if it is not the JSON form)."""
    try:
        obj = json.loads(payload)
    except ValueError:
        return payload.decode("utf-8", "replace")[:500]
    if isinstance(obj, dict) and "message" in obj:
        return f"{obj.get('error', 'error')}: {obj['message']}"
    return payload.decode("utf-8", "replace")[:500]
