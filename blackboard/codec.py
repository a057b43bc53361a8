"""Wire codec: msgpack between modules, JSON for people and standard Zenoh tools."""

from __future__ import annotations

import json
import math
from typing import Any

import msgpack

from blackboard.errors import BadRequestError

__all__ = ["encode", "decode", "pack_array_of_packed", "MAX_PAYLOAD"]

#: Largest payload the node accepts [bytes].
MAX_PAYLOAD = 64 * 1024 * 1024



def _json_default(o: Any) -> Any:
    if isinstance(o, (bytes, bytearray)):
        return o.hex()
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    raise TypeError(f"{type(o).__name__} is not JSON serialisable")


def encode(obj: Any, *, as_json: bool = False) -> bytes:
    """Encode a wire object as msgpack (default) or JSON (UTF-8)."""
    if as_json:
        return json.dumps(obj, default=_json_default, allow_nan=False, separators=(",", ":")).encode()
    return msgpack.packb(obj, use_bin_type=True)


def pack_array_of_packed(items: list[bytes]) -> bytes:
    """Return the msgpack array whose elements are the given already-packed values."""
    n = len(items)
    if n < 16:
        head = bytes((0x90 | n,))
    elif n < 0x10000:
        head = b"\xdc" + n.to_bytes(2, "big")
    else:
        head = b"\xdd" + n.to_bytes(4, "big")
    return head + b"".join(items)


def _no_const(c: str) -> float:
    raise ValueError(f"{c} is not allowed")


def decode(payload: bytes, *, as_json: bool = False) -> Any:
    """Decode a wire payload; raise BadRequestError saying what is wrong."""
    if len(payload) > MAX_PAYLOAD:
        raise BadRequestError(f"payload of {len(payload)} bytes exceeds the {MAX_PAYLOAD}-byte limit")
    try:
        if as_json:
            return json.loads(payload.decode("utf-8"), parse_constant=_no_const)
        return msgpack.unpackb(payload, raw=False, strict_map_key=True, max_bin_len=MAX_PAYLOAD)
    except RecursionError:
        raise BadRequestError("payload nests too deeply") from None
    except (ValueError, UnicodeDecodeError, msgpack.ExtraData, msgpack.FormatError, msgpack.StackError, TypeError) as exc:
        kind = "JSON" if as_json else "msgpack"
        raise BadRequestError(f"payload is not valid {kind}: {exc}"[:300]) from None
    except Exception as exc:  # noqa: BLE001 - msgpack raises assorted errors on garbage
        kind = "JSON" if as_json else "msgpack"
        raise BadRequestError(f"payload is not valid {kind}: {type(exc).__name__}: {exc}"[:300]) from None


def finite(x: object) -> bool:
    """Return True for a real finite number (not bool)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


__all__ += ["finite"]
