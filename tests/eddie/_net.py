"""Loopback Zenoh settings for EDDIE's tests (multicast off, explicit endpoints)."""

from __future__ import annotations

from wire.network import NetworkConfig
from wire.ports import free_port

__all__ = ["net_pair"]


def net_pair(ns: str) -> tuple[NetworkConfig, NetworkConfig, str]:
    """Return (listener, connector, endpoint) peer configs on a fresh loopback port."""
    ep = f"tcp/127.0.0.1:{free_port()}"
    return NetworkConfig(namespace=ns, listen=(ep,)), NetworkConfig(namespace=ns, connect=(ep,)), ep
