"""Rate-limited warnings: a warning that can repeat per message (bad payloads, dropped messages) is
logged once per `every_s` [s] wall per kind, saying how many like it were held back meanwhile."""

from __future__ import annotations

import logging
import threading
import time

__all__ = ["warn_limited", "WARN_EVERY_S"]

#: The default window [s] wall: at most one warning of a kind per window.
WARN_EVERY_S = 10.0

_lock = threading.Lock()
#: (logger name, kind) → (when the newest was logged [s, time.monotonic], how many were held back since)
_seen: dict[tuple[str, str], tuple[float, int]] = {}
_MAX_KINDS = 4096


def warn_limited(logger: logging.Logger, kind: str, msg: str, *args: object, every_s: float = WARN_EVERY_S,
                 level: int = logging.WARNING) -> bool:
    """Log `msg % args` unless a warning of `kind` was logged less than `every_s` [s] ago; return whether it was logged.

    Safe from any thread (Zenoh callbacks included); `kind` is a short fixed label, never the payload.
    """
    now = time.monotonic()
    key = (logger.name, kind)
    with _lock:
        last, held = _seen.get(key, (-float("inf"), 0))
        if now - last < every_s:
            _seen[key] = (last, held + 1)
            return False
        if len(_seen) >= _MAX_KINDS and key not in _seen:
            _seen.pop(next(iter(_seen)))
        _seen[key] = (now, 0)
    if held:
        logger.log(level, msg + " (%d more like this in the last %.0f s)", *args, held, every_s)
    else:
        logger.log(level, msg, *args)
    return True
