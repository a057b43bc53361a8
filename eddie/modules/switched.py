"""The life of a triggered EDDIE module: asleep until a `ModuleSwitch` wakes it, then one cycle after another."""

from __future__ import annotations

import logging
from typing import Awaitable, Callable

from eddie.errors import EddieError
from eddie.messages.modules import ModuleSwitch
from eddie.toolkit.module import Module

__all__ = ["Switch", "run_switched"]

log = logging.getLogger(__name__)


class Switch:
    """Whether the module is awake, and in which mode; set by the triggers' `ModuleSwitch` messages."""

    def __init__(self, awake: bool) -> None:
        self.awake = awake
        self.mode = ""

    def take(self, name: str, msg: object) -> None:
        """Apply an inbox message (anything but a `ModuleSwitch` is ignored)."""
        if isinstance(msg, ModuleSwitch):
            self.awake, self.mode = msg.on, msg.mode
            log.info("%s %s%s (%s)", name, "awake" if msg.on else "asleep", f" [{msg.mode}]" if msg.mode else "", msg.reason)


async def run_switched(m: Module, switch: Switch, cycle: Callable[[], Awaitable[str]], *, period_s: float) -> None:
    """Say ready, then forever: read the inbox, sleep while asleep, else run `cycle` every `period_s` [s] sim."""
    m.ready()
    await m.clock.wait_running()
    while True:
        try:
            while m.pending():
                switch.take(m.name, (await m.receive(timeout=0.1)).message)
            if not switch.awake:
                switch.take(m.name, (await m.receive()).message)
                continue
            log.debug("%s: %s", m.name, await cycle())
        except EddieError as exc:  # a bad message, a capture that failed: log it, go on
            log.warning("%s: %s", m.name, exc)
        await m.clock.sleep(period_s)
