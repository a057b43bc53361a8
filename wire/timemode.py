"""Which time a process runs in: real time, or lock-step with the simulator (`wire.lockstep`).

Kept apart from `wire.lockstep` (which needs the Zenoh session) so that pure cores — the planners —
can ask without importing zenoh.
"""

from __future__ import annotations

import os

__all__ = ["LOCKSTEP_ENV", "lockstep_enabled", "lockstep_env"]

#: The environment variable that makes a process take part in lock-step ("1") and count instead of timing.
LOCKSTEP_ENV = "SIDEWALK_LOCKSTEP"


def lockstep_enabled() -> bool:
    """Return whether this process runs in lock-step (`SIDEWALK_LOCKSTEP=1`)."""
    return os.environ.get(LOCKSTEP_ENV, "") == "1"


def lockstep_env(hash_seed: int = 0) -> tuple[tuple[str, str], ...]:
    """Return the environment a lock-step child process gets: the switch, and a fixed hash seed (set iteration order)."""
    return ((LOCKSTEP_ENV, "1"), ("PYTHONHASHSEED", str(int(hash_seed))))
