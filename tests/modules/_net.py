"""Loopback Zenoh settings for the modules' integration tests: free ports, listener/connector configs."""

from __future__ import annotations

import socket

from blackboard.network import NetworkConfig

__all__ = ["free_port", "net_pair"]


def free_port() -> int:
    """Return a TCP port on 127.0.0.1 that is free right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def net_pair(ns: str) -> tuple[NetworkConfig, NetworkConfig, str]:
    """Return (listener, connector, endpoint) peer configs on a fresh loopback port, multicast off."""
    ep = f"tcp/127.0.0.1:{free_port()}"
    return (
        NetworkConfig(namespace=ns, listen=(ep,)),
        NetworkConfig(namespace=ns, connect=(ep,)),
        ep,
    )
