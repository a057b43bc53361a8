"""Ask the simulator's scanner for one laser image (no camera) on a CODGER module's Zenoh link."""

from __future__ import annotations

import json

from wire.capture import CaptureResult, decode_capture
from wire.keys import SimKeys

__all__ = ["laser_capture"]


async def laser_capture(rt, timeout_s: float) -> CaptureResult:  # noqa: ANN001 - a module runtime
    """Return the first laser image the simulator answers within `timeout_s` [s] wall (TimeoutError when none does)."""
    req = json.dumps({"laser": True, "camera": False}).encode()
    key = SimKeys(rt.net.namespace).capture
    replies = await rt.link.get(key, payload=req, timeout=timeout_s)
    for r in replies:
        if r.ok:
            return decode_capture(r.payload)
    raise TimeoutError(f"no simulator answered {key}")
