"""Network settings shared by every Sidewalk process: namespace, Zenoh mode and endpoints.

The deployment (see README "Several hosts"): one Zenoh **router** per system (`sidewalk up router`,
started first by `sidewalk run`) listens on the system's endpoint; every module, the blackboard node
and the simulator are **peers** that connect to it, learn about each other through its gossip and
then talk directly (each peer listens on an ephemeral port); command-line tools (`status`, `submit`,
`cancel`, `bb …`) are **clients** of the router. Multicast scouting is off: endpoints are explicit.
"""

from __future__ import annotations

import ipaddress
from typing import Literal

from pydantic import BaseModel, ConfigDict, field_validator

__all__ = ["NetworkConfig", "DEFAULT_ENDPOINT", "Mode", "check_chunk"]

#: Where the system's router listens, and everything else connects, when no endpoint is given.
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"

Mode = Literal["peer", "client", "router"]

_CHUNK_ALLOWED = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.")


def check_chunk(name: str, what: str = "name") -> str:
    """Return `name` if it is one key chunk (letters, digits, '_', '-', '.'); raise ValueError naming `what`."""
    if not name or not set(name) <= _CHUNK_ALLOWED:
        raise ValueError(f"{what} {name!r} must be non-empty and use only letters, digits, '_', '-', '.'")
    return name


def _host_of(endpoint: str) -> str:
    """Return the host part of `proto/host:port` (brackets of IPv6 removed)."""
    addr = endpoint.partition("/")[2].split("#", 1)[0]
    host = addr.rsplit(":", 1)[0] if ":" in addr else addr
    return host.strip("[]")


def _is_loopback(endpoint: str) -> bool:
    host = _host_of(endpoint)
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class NetworkConfig(BaseModel):
    """Zenoh session settings and the key-expression namespace (`sidewalk/<namespace>/…`)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    namespace: str = "default"
    mode: Mode = "peer"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    multicast_scouting: bool = False

    @field_validator("namespace")
    @classmethod
    def _check_namespace(cls, v: str) -> str:
        return check_chunk(v, "namespace")

    @field_validator("connect", "listen")
    @classmethod
    def _check_endpoints(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        for ep in v:
            proto, sep, rest = ep.partition("/")
            if not sep or not proto or not rest:
                raise ValueError(f"endpoint {ep!r} is not of the form PROTO/ADDRESS (e.g. tcp/127.0.0.1:7447)")
        return v

    def with_defaults(self) -> "NetworkConfig":
        """Return a copy with the default endpoint filled in: a router listens on it, the others connect to it."""
        if self.connect or self.listen:
            return self
        if self.mode == "router":
            return self.model_copy(update={"listen": (DEFAULT_ENDPOINT,)})
        return self.model_copy(update={"connect": (DEFAULT_ENDPOINT,)})

    def as_tool(self) -> "NetworkConfig":
        """Return the settings a command-line tool uses: a client of the router (unless a mode was forced)."""
        return self.model_copy(update={"mode": "client"}) if self.mode == "peer" else self

    @property
    def endpoints(self) -> tuple[str, ...]:
        """Return every endpoint named (connect, then listen), for messages."""
        return self.connect + self.listen

    def peer_listen(self) -> tuple[str, ...]:
        """Return what a peer listens on so other peers can reach it directly (ephemeral port)."""
        if self.listen or self.mode != "peer":
            return self.listen
        if not self.connect or all(_is_loopback(ep) for ep in self.connect):
            return ("tcp/127.0.0.1:0",)
        return ("tcp/0.0.0.0:0",)

    def zenoh_json(self) -> dict:
        """Return the Zenoh configuration as a JSON-able dict (zenoh 1.x schema)."""
        cfg: dict = {
            "mode": self.mode,
            "scouting": {"multicast": {"enabled": self.multicast_scouting}, "gossip": {"enabled": True}},
        }
        if self.connect:
            cfg["connect"] = {"endpoints": list(self.connect)}
        listen = self.peer_listen()
        if listen:
            cfg["listen"] = {"endpoints": list(listen)}
        return cfg
