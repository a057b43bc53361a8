"""What both architectures have: the simulator (clock, truth, events, previews, map and world), process
health (liveliness, heartbeats) and the CAPTAIN's mission events — decoded values fed into the model.

`on_sample(rel_key, value)` takes a key below `sidewalk/<ns>/` and its decoded value (a dict from
msgpack live, or from a recording's JSON): the live monitor and the replay share it.
"""

from __future__ import annotations

import base64
import logging
from typing import Any

from pydantic import ValidationError

from sidewalk.mapdraw import drawable_features
from sidewalk.values import num as _f
from sidewalk.monitor.model import MonitorModel, XYPose
from wire.health import Heartbeat

__all__ = ["SimSource", "image_bytes"]

log = logging.getLogger(__name__)


def image_bytes(v: Any) -> bytes | None:
    """Return encoded image bytes given as bytes (live) or base64 text (a recording)."""
    if isinstance(v, (bytes, bytearray, memoryview)):
        return bytes(v)
    if isinstance(v, str):
        try:
            return base64.b64decode(v, validate=True)
        except ValueError:
            return None
    return None


class SimSource:
    """Feed `model` from the simulator's keys, heartbeats, liveliness and mission events."""

    def __init__(self, model: MonitorModel) -> None:
        self.model = model
        self.bad = 0

    def on_alive(self, name: str, alive: bool) -> None:
        """A process's liveliness token appeared (alive) or went; blackboard clients are not listed."""
        if "/" in name:
            return
        self.model.liveliness(name, alive)

    def on_sample(self, rel: str, v: Any, *, received: float | None = None) -> bool:
        """Handle one decoded sample; return whether the key was one of ours."""
        m = self.model
        if not isinstance(v, dict):
            return False
        if rel == "sim/truth":
            m.set_truth(XYPose(t=_f(v.get("stamp")), x=_f(v.get("x")), y=_f(v.get("y")), yaw=_f(v.get("yaw"))), _f(v.get("v")))
        elif rel == "sim/clock":
            m.sim_time(_f(v.get("stamp")), v.get("rtf_actual"))
        elif rel == "sim/preview":
            for name in ("camera", "colored_range"):
                img = v.get(name)
                if isinstance(img, dict):
                    data = image_bytes(img.get("data"))
                    if data:
                        m.image(name, data, fmt=str(img.get("format", "jpeg")), width=int(img.get("width", 0) or 0),
                                height=int(img.get("height", 0) or 0), stamp=_f(v.get("stamp")))
        elif rel == "sim/events":
            m.event({k: v.get(k) for k in ("stamp", "kind", "x", "y", "object_id", "object_kind", "detail")})
        elif rel.startswith("heartbeat/"):
            try:
                m.heartbeat(Heartbeat.model_validate(v), received)
            except ValidationError:
                self.bad += 1
        elif rel == "mission/events":
            m.mission(v)
        elif rel in ("sim/map", "sim/world"):
            m.set_map(drawable_features(v), truth=rel == "sim/world")
        else:
            return False
        return True
