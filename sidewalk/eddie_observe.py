"""What an EDDIE run's observer reads off the wire: the controller's `local` pose, the navigator's transform, triggers fired.

The observer is evaluation code, not an EDDIE module, so it reads the three streams through narrow
views (frozen models that ignore the fields they do not need) and does not depend on how the
controller, the navigator and the map manager spell the rest of their messages. Streams carry the
bare message fields as msgpack (`eddie.toolkit.message.encode_body`).
"""

from __future__ import annotations

import logging
from typing import Any

from pydantic import BaseModel, ConfigDict

from eddie.errors import BadMessage
from eddie.toolkit.message import Message, decode_body
from sidewalk.run_record import FiredTrigger
from wire.aio import Link
from wire.keys import EddieKeys
from wire.se2 import PoseFields

__all__ = ["LocalPoseView", "TransformView", "TriggerView", "subscribe_eddie", "STREAMS"]

log = logging.getLogger(__name__)

#: (module, stream) of each stream the observer reads
STREAMS = {"state": ("controller", "state"), "transform": ("navigator", "world_from_local"),
           "triggers": ("map_manager", "triggers")}

_VIEW = ConfigDict(frozen=True, extra="ignore")


class LocalPoseView(PoseFields, Message):
    """The controller's state as the observer needs it: the dead-reckoned pose in `local` at `stamp` [s] sim."""

    model_config = _VIEW

    stamp: float
    x: float
    y: float
    yaw: float


class TransformView(PoseFields, Message):
    """The navigator's `world` ← `local` (x [m], y [m], yaw [rad]) as of `stamp` [s] sim (its newest fix)."""

    model_config = _VIEW

    stamp: float = 0.0
    x: float
    y: float
    yaw: float


class TriggerView(Message):
    """A trigger fired: when [s] sim, where (x, y [m] `world`), which annotation, its type, its destination."""

    model_config = _VIEW

    stamp: float
    x: float
    y: float
    annotation_id: str
    trigger_type: str
    destination: str
    text: str = ""
    #: fired, skipped (a position jump passed it) or rearmed: only fired ones go into the report
    event: str = "fired"


def _reader(model: type[BaseModel], stream: str, on: Any):
    def on_sample(_key: str, payload: bytes) -> None:
        try:
            msg = decode_body(model, payload, sender=stream)  # type: ignore[arg-type]
        except BadMessage as exc:
            log.warning("observer: stream %s: %s", stream, exc)
            return
        on(msg)

    return on_sample


def subscribe_eddie(link: Link, keys: EddieKeys, pose: Any, triggers: list[FiredTrigger]) -> None:
    """Feed `pose` (a `sidewalk.eddie_run.PoseComposer`) from the controller and navigator streams; append each trigger fired."""
    c_mod, c_stream = STREAMS["state"]
    n_mod, n_stream = STREAMS["transform"]
    t_mod, t_stream = STREAMS["triggers"]
    link.subscribe(keys.topic(c_mod, c_stream), _reader(
        LocalPoseView, f"{c_mod}/{c_stream}", lambda m: pose.set_local(m.stamp, m.to_pose2d().as_tuple())))
    link.subscribe(keys.topic(n_mod, n_stream), _reader(
        TransformView, f"{n_mod}/{n_stream}", lambda m: pose.set_world_from_local(m.to_pose2d().as_tuple(), m.stamp)))
    link.subscribe(keys.topic(t_mod, t_stream), _reader(
        TriggerView, f"{t_mod}/{t_stream}", lambda m: m.event == "fired" and triggers.append(FiredTrigger(
            sim_s=m.stamp, x=m.x, y=m.y, annotation=m.annotation_id, kind=m.trigger_type, destination=m.destination, text=m.text))))
