"""Watch another module: its liveliness token (gone too long?) and its heartbeat (silent: wedged?)."""

from __future__ import annotations

import asyncio
import time

from wire.aio import Link
from wire.keys import ModuleKeys
from runtime.heartbeat import HeartbeatError, HeartbeatTracker, decode_heartbeat

__all__ = ["ModuleWatch", "HeartbeatWatch"]


class ModuleWatch:
    """The liveliness of module `name`: None until first seen either way, then True/False."""

    def __init__(self, link: Link, keys: ModuleKeys, name: str) -> None:
        self.name = name
        self.key = keys.alive(name)
        self.alive: bool | None = None
        self._changed = asyncio.Event()
        link.watch_alive(self.key, self._on_change)

    def _on_change(self, key: str, alive: bool) -> None:
        if key == self.key:
            self.alive = alive
            self._changed.set()

    def observe(self, alive: bool) -> None:
        """Record a liveliness change (what the Zenoh watch calls; on the loop)."""
        self._on_change(self.key, alive)

    async def wait_alive(self) -> None:
        """Return once the module is alive."""
        while self.alive is not True:
            self._changed.clear()
            await self._changed.wait()

    async def lost(self, grace_s: float) -> str:
        """Return a reason once the module's token has been gone for longer than `grace_s` wall seconds [s].

        A module never seen is not lost: only one that was alive and went away (or was seen gone).
        """
        while True:
            while self.alive is not False:
                self._changed.clear()
                await self._changed.wait()
            gone_at = time.monotonic()
            while self.alive is False:
                left = grace_s - (time.monotonic() - gone_at)
                if left <= 0:
                    return f"{self.name} stopped (no liveliness for {grace_s:.0f} s)"
                self._changed.clear()
                try:
                    await asyncio.wait_for(self._changed.wait(), left)
                except asyncio.TimeoutError:
                    pass


class HeartbeatWatch:
    """The heartbeat of module `name`: silent once no beat came for `silent_after` of its periods (a wedged process keeps its token)."""

    def __init__(self, link: Link, keys: ModuleKeys, name: str, *, silent_after: float = 1.5) -> None:
        self.name = name
        self.tracker = HeartbeatTracker(grace=silent_after)

        def on_beat(_key: str, payload: bytes) -> None:
            try:
                self.tracker.observe(decode_heartbeat(payload))
            except HeartbeatError:
                pass

        link.subscribe(keys.heartbeat(name), on_beat)

    @property
    def silent(self) -> bool:
        """Return whether the module, heard once, has not beaten for `silent_after` of its periods [s wall]."""
        return bool(self.tracker.stale())
