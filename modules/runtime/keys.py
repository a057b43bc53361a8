"""Zenoh key expressions the Sidewalk modules use outside the blackboard, under `sidewalk/<ns>/…`."""

from __future__ import annotations

__all__ = ["ModuleKeys", "check_name"]

_ALLOWED = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.")


def check_name(name: str, what: str = "name") -> str:
    """Return `name` if it is a single key chunk (letters, digits, '_', '-', '.'); raise ValueError."""
    if not name or not set(name) <= _ALLOWED:
        raise ValueError(f"{what} {name!r} must be non-empty and use only letters, digits, '_', '-', '.'")
    return name


class ModuleKeys:
    """Build the key expressions of one namespace: liveliness, heartbeats, sim clock, missions."""

    def __init__(self, namespace: str) -> None:
        self.ns = check_name(namespace, "namespace")
        self.root = f"sidewalk/{self.ns}"

    def alive(self, module: str) -> str:
        """Return the liveliness token key of `module` (declared once the module is ready)."""
        return f"{self.root}/alive/{check_name(module, 'module name')}"

    @property
    def alive_all(self) -> str:
        """Return the key expression matching every module's liveliness token."""
        return f"{self.root}/alive/*"

    def heartbeat(self, module: str) -> str:
        """Return the heartbeat key of `module`."""
        return f"{self.root}/heartbeat/{check_name(module, 'module name')}"

    @property
    def heartbeat_all(self) -> str:
        """Return the key expression matching every module's heartbeat."""
        return f"{self.root}/heartbeat/*"

    @property
    def sim_clock(self) -> str:
        """Return the simulator's clock key (sim time [s])."""
        return f"{self.root}/sim/clock"

    @property
    def mission_submit(self) -> str:
        """Return the CAPTAIN's mission submission queryable key (YAML or JSON payload)."""
        return f"{self.root}/mission/submit"

    def mission_status(self, mission_id: str = "*") -> str:
        """Return the CAPTAIN's mission status queryable key (one mission, or `*` for all)."""
        if mission_id != "*":
            check_name(mission_id, "mission id")
        return f"{self.root}/mission/status/{mission_id}"

    @property
    def mission_cancel(self) -> str:
        """Return the CAPTAIN's mission cancel queryable key (payload: the mission id)."""
        return f"{self.root}/mission/cancel"
