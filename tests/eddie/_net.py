"""Loopback Zenoh settings for EDDIE's tests (multicast off, explicit endpoints)."""

from __future__ import annotations

import asyncio
from typing import Awaitable, Callable, TypeVar

from wire.network import NetworkConfig
from wire.ports import free_port

from eddie.errors import LinkTimeout, NoSuchModule, ServiceError

__all__ = ["net_pair", "retry"]

T = TypeVar("T")


async def retry(ask: Callable[[], Awaitable[T]], timeout: float = 30.0) -> T:
    """Return `await ask()` once the service it asks is up (NoSuchModule / ServiceError / LinkTimeout until then; wall [s])."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while True:
        try:
            return await ask()
        except (NoSuchModule, ServiceError, LinkTimeout):
            if loop.time() > deadline:
                raise
            await asyncio.sleep(0.1)


def net_pair(ns: str) -> tuple[NetworkConfig, NetworkConfig, str]:
    """Return (listener, connector, endpoint) peer configs on a fresh loopback port."""
    ep = f"tcp/127.0.0.1:{free_port()}"
    return NetworkConfig(namespace=ns, listen=(ep,)), NetworkConfig(namespace=ns, connect=(ep,)), ep
