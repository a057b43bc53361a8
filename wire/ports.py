"""Free TCP ports on loopback, for runs and tests that need an endpoint nobody else uses."""

from __future__ import annotations

import socket

__all__ = ["free_port", "free_endpoint"]


def free_port(host: str = "127.0.0.1") -> int:
    """Return a TCP port that is free on `host` right now (the OS picks it)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def free_endpoint(host: str = "127.0.0.1") -> str:
    """Return a Zenoh TCP endpoint `tcp/HOST:PORT` on a free port."""
    return f"tcp/{host}:{free_port(host)}"
