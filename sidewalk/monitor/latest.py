"""Latest-value-wins subscriptions: a Zenoh callback only stores the newest payload of its key.

For high-rate streams the monitor draws but need not see every sample of (truth, clock, poses,
previews): the Zenoh thread stores the payload under a lock held for a dict store and wakes the
loop at most once per batch; the loop then handles the newest payload of each key. A busy loop or
a slow page therefore drops samples, never holds up Zenoh.
"""

from __future__ import annotations

import asyncio
import threading
from typing import Any, Callable

from wire.session import Session

__all__ = ["LatestSubscriber"]


class LatestSubscriber:
    """Call `handler(key, payload)` on `loop` with the newest payload of each subscribed key."""

    def __init__(self, session: Session, loop: asyncio.AbstractEventLoop, handler: Callable[[str, bytes], None]) -> None:
        self._session = session
        self._loop = loop
        self._handler = handler
        self._lock = threading.Lock()
        self._latest: dict[str, bytes] = {}
        self._scheduled = False
        #: samples received and samples handed to the handler
        self.received = 0
        self.handled = 0

    def subscribe(self, key_expr: str) -> Any:
        """Subscribe to `key_expr` (wildcards keep one newest payload per concrete key)."""
        return self._session.subscribe_payload(key_expr, self._on_payload)

    def _on_payload(self, key: str, payload: bytes) -> None:  # Zenoh thread
        with self._lock:
            self.received += 1
            self._latest[key] = payload
            if self._scheduled:
                return
            self._scheduled = True
        try:
            self._loop.call_soon_threadsafe(self._flush)
        except RuntimeError:  # the loop is closed: shutting down
            pass

    def _flush(self) -> None:  # the loop
        with self._lock:
            items, self._latest = self._latest, {}
            self._scheduled = False
        for key, payload in items.items():
            self.handled += 1
            self._handler(key, payload)
