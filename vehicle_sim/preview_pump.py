"""The simulator's sensor preview, made beside the captures rather than after each one.

A preview (two small JPEGs, `vehicle_sim.preview`) is for the live views and the recording; nothing
decides on it. Made on the capture worker after every reply, it was 6.6 % of a lock-step EDDIE run's
simulator time and held the next capture back (issue 39). The pump keeps only the newest capture
handed to it and makes the preview of that on its own thread, at most one every `period_s` [s wall]:
a capture superseded before its turn gets none (a preview's `seq` still counts every capture rendered).
"""

from __future__ import annotations

import logging
import threading
from typing import Callable

from wire.capture import CaptureResult

__all__ = ["PreviewPump", "PREVIEW_PERIOD_S"]

log = logging.getLogger(__name__)

#: at most one preview per this many wall seconds [s] (the live views refresh a few times a second)
PREVIEW_PERIOD_S = 0.2


class PreviewPump:
    """Publish the preview of the newest capture offered, on a thread of its own, at most once per `period_s` [s wall]."""

    def __init__(self, put: Callable[[bytes], None], *, period_s: float = PREVIEW_PERIOD_S) -> None:
        """`put` sends a preview's bytes (a droppable publisher's put: it must not block)."""
        self._put = put
        self.period_s = period_s
        self._newest: tuple[CaptureResult, int] | None = None
        self._lock = threading.Lock()
        self._ready = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.published = 0

    def start(self) -> None:
        """Start the pump's thread."""
        self._thread = threading.Thread(target=self._run, name="sim-preview", daemon=True)
        self._thread.start()

    def offer(self, result: CaptureResult, seq: int) -> None:
        """Hand over a capture just rendered (`seq`: captures rendered so far); returns at once."""
        with self._lock:
            self._newest = (result, seq)
        self._ready.set()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the thread (idempotent); a preview being made is finished first."""
        self._stop.set()
        self._ready.set()
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None

    def _run(self) -> None:
        from vehicle_sim.preview import make_preview
        from wire.preview import encode_preview

        while not self._stop.is_set():
            self._ready.wait()
            self._ready.clear()
            with self._lock:
                item, self._newest = self._newest, None
            if item is None or self._stop.is_set():
                continue
            try:
                self._put(encode_preview(make_preview(*item)))
                self.published += 1
            except Exception:  # noqa: BLE001 - a preview must never disturb the simulator
                log.exception("preview failed")
            self._stop.wait(self.period_s)
