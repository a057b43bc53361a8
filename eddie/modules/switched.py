"""The life of a triggered EDDIE module: asleep until a trigger wakes it, then one cycle after another.

What wakes or switches a module: a `ModuleSwitch` in its inbox, or a trigger the annotated map
manager delivers (`map_manager.trigger`, its data an envelope of one of the seed's trigger types):
resume vision, use vision through an intersection (wake), dead reckon through an intersection
(sleep), start / stop landmark matching, start / stop fast obstacle detection (`on`), switch
perception modules (mode). Any other trigger data is kept in `Switch.last` for the module to act on.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Awaitable, Callable

import base64

from eddie.errors import EddieError
from eddie.messages.modules import ModuleSwitch
from eddie.toolkit.message import Message, decode_envelope, message_name
from eddie.toolkit.module import Module

__all__ = ["Switch", "run_switched"]

log = logging.getLogger(__name__)


#: trigger data type → (awake, mode); None: the data's own `on` field says
_TRIGGER_SWITCHES: dict[str, tuple[bool | None, str]] = {
    "map_manager.resume_vision": (True, ""),
    "map_manager.vision_through_intersection": (True, "through_intersection"),
    "map_manager.dead_reckon_through": (False, "dead_reckon"),
    "map_manager.landmark_matching": (None, ""),
    "map_manager.obstacle_detection": (None, ""),
}


def trigger_data(msg: Message) -> Message | None:
    """Return the typed message in a delivered trigger's data (None: not a trigger, or data that does not decode)."""
    raw = getattr(msg, "data_base64", None)
    if raw is None or message_name(msg) != "map_manager.trigger":
        return None
    try:
        return decode_envelope(base64.b64decode(raw), where="trigger data")[1]
    except (EddieError, ValueError) as exc:
        log.warning("trigger %s: %s", getattr(msg, "annotation_id", "?"), exc)
        return None


class Switch:
    """Whether the module is awake, in which mode, and the newest trigger data it was sent."""

    def __init__(self, awake: bool) -> None:
        self.awake = awake
        self.mode = ""
        self.last: Message | None = None
        #: the mission the mission service last switched the module for ("": none yet), and whether it
        #: said the mission started (True) or ended (False)
        self.mission_id = ""
        self.mission_running = False
        #: how many triggers and switches were taken so far (a cycle compares it across its slow part)
        self.taken = 0

    def _set(self, name: str, on: bool, mode: str, why: str) -> None:
        self.awake, self.mode = on, mode
        log.info("%s %s%s (%s)", name, "awake" if on else "asleep", f" [{mode}]" if mode else "", why)

    def take(self, name: str, msg: Message) -> None:
        """Apply an inbox message: a `ModuleSwitch`, or a trigger; anything else is ignored."""
        if isinstance(msg, ModuleSwitch):
            self.taken += 1
            if msg.mission_id:
                self.mission_id, self.mission_running = msg.mission_id, msg.on
            self._set(name, msg.on, msg.mode, msg.reason)
            return
        data = trigger_data(msg)
        if data is None:
            return
        self.taken += 1
        self.last = data
        kind = message_name(data)
        why = f"trigger {getattr(msg, 'annotation_id', '?')} {kind}"
        if kind in _TRIGGER_SWITCHES:
            on, mode = _TRIGGER_SWITCHES[kind]
            self._set(name, bool(getattr(data, "on", True)) if on is None else on, mode, why)
        elif kind == "map_manager.switch_perception":
            self._set(name, True, str(getattr(data, "module", "")), why)


async def run_switched(m: Module, switch: Switch, cycle: Callable[[], Awaitable[str]], *, period_s: float,
                       on_data: Callable[[Message], Awaitable[None]] | None = None) -> None:
    """Say ready, then read the inbox and run `cycle` every `period_s` [s] sim while awake, side by side.

    The inbox is read by its own task, so a trigger is acted on as it arrives even while a cycle is
    busy perceiving or planning (seconds of sim at a high RTF); `on_data` is called with each
    trigger's data after the switch took it (a module's own action). A cycle that must not act on
    a switch it has not seen compares `switch.taken` before and after its slow part.
    """
    m.ready()
    await m.clock.wait_running()
    woken = asyncio.Event()

    async def inbox() -> None:
        while True:
            try:
                inc = await m.receive()
                switch.last = None
                switch.take(m.name, inc.message)
                if switch.last is not None and on_data is not None:
                    await on_data(switch.last)
            except EddieError as exc:  # a bad message: log it, read on
                log.warning("%s: %s", m.name, exc)
            if switch.awake:
                woken.set()

    reader = asyncio.ensure_future(inbox())
    try:
        while True:
            if not switch.awake:
                woken.clear()
                await woken.wait()
                continue
            try:
                done = await cycle()
                log.debug("%s: t=%.2f %s", m.name, m.clock.now_or(-1.0), done)
            except EddieError as exc:  # a capture that failed, a refused request: log it, go on
                log.warning("%s: %s", m.name, exc)
            await m.clock.sleep(period_s)
    finally:
        reader.cancel()
