"""Network settings shared by every Sidewalk process: namespace and Zenoh endpoints."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, field_validator

__all__ = ["NetworkConfig", "DEFAULT_ENDPOINT"]

#: Where the blackboard node listens, and everyone else connects, when no endpoint is given.
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"

_NS_ALLOWED = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.")


class NetworkConfig(BaseModel):
    """Zenoh session settings and the key-expression namespace (`sidewalk/<namespace>/…`).

    Multicast scouting is off unless asked for: endpoints are explicit.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    namespace: str = "default"
    mode: Literal["peer", "client", "router"] = "peer"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    multicast_scouting: bool = False

    @field_validator("namespace")
    @classmethod
    def _check_namespace(cls, v: str) -> str:
        if not v or not set(v) <= _NS_ALLOWED:
            raise ValueError(
                f"namespace {v!r} must be non-empty and use only letters, digits, '_', '-', '.'"
            )
        return v

    @field_validator("connect", "listen")
    @classmethod
    def _check_endpoints(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        for ep in v:
            proto, sep, rest = ep.partition("/")
            if not sep or not proto or not rest:
                raise ValueError(f"endpoint {ep!r} is not of the form PROTO/ADDRESS (e.g. tcp/127.0.0.1:7447)")
        return v

    def with_defaults(self, *, serve: bool) -> "NetworkConfig":
        """Return a copy that listens (serve=True) or connects on DEFAULT_ENDPOINT if nothing is set."""
        if self.connect or self.listen:
            return self
        if serve:
            return self.model_copy(update={"listen": (DEFAULT_ENDPOINT,)})
        return self.model_copy(update={"connect": (DEFAULT_ENDPOINT,)})

    def zenoh_json(self) -> dict:
        """Return the Zenoh configuration as a JSON-able dict (zenoh 1.x schema)."""
        cfg: dict = {
            "mode": self.mode,
            "scouting": {"multicast": {"enabled": self.multicast_scouting}},
        }
        if self.connect:
            cfg["connect"] = {"endpoints": list(self.connect)}
        if self.listen:
            cfg["listen"] = {"endpoints": list(self.listen)}
        return cfg
