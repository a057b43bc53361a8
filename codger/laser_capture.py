"""Ask the simulator's capture service for one capture (a laser image alone, by default) on a CODGER module's Zenoh link."""

from __future__ import annotations

import json

from wire.capture import CaptureResult, decode_capture
from wire.keys import SimKeys

__all__ = ["LASER_ALONE", "capture", "laser_capture"]

#: the request for a laser image alone (no camera)
LASER_ALONE = {"laser": True, "camera": False}


async def laser_capture(rt, timeout_s: float) -> CaptureResult:  # noqa: ANN001 - a module runtime
    """Return the first laser image the simulator answers within `timeout_s` [s] wall (TimeoutError when none does)."""
    return await capture(rt, LASER_ALONE, timeout_s)


async def capture(rt, request: dict, timeout_s: float) -> CaptureResult:  # noqa: ANN001 - a module runtime
    """Return the first capture of `request` (the capture service's JSON) the simulator answers within `timeout_s` [s] wall
    (TimeoutError when none does)."""
    req = json.dumps(request).encode()
    key = SimKeys(rt.net.namespace).capture
    replies = await rt.link.get(key, payload=req, timeout=timeout_s)
    for r in replies:
        if r.ok:
            return decode_capture(r.payload)
    raise TimeoutError(f"no simulator answered {key}")
