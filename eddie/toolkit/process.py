"""Run an EDDIE module as a process: open its endpoint, wait for the network, run until done or SIGINT/SIGTERM."""

from __future__ import annotations

import asyncio
import logging
import signal
import sys
from typing import Any, Awaitable, Callable

from wire.network import NetworkConfig

from eddie.toolkit.module import Module

__all__ = ["ModuleMain", "run_module", "run_module_async"]

log = logging.getLogger(__name__)

#: What a module provides: an async function of its endpoint; returning ends the module.
ModuleMain = Callable[[Module], Awaitable[None]]


async def run_module_async(name: str, main: ModuleMain, net: NetworkConfig, *, install_signals: bool = True,
                           **module_kw: Any) -> int:
    """Run `main(module)` as EDDIE module `name` until it returns or a stop signal; return the exit code."""
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    installed: list[int] = []
    code = 0
    async with Module(name, net, **module_kw) as module:
        if install_signals:
            for sig in (signal.SIGINT, signal.SIGTERM):
                try:
                    loop.add_signal_handler(sig, stop.set)
                    installed.append(sig)
                except (NotImplementedError, RuntimeError):
                    pass

        async def body() -> None:
            await module.wait_connected(None)
            await main(module)

        main_task = loop.create_task(body())
        stop_task = loop.create_task(stop.wait())
        try:
            done, _ = await asyncio.wait({main_task, stop_task}, return_when=asyncio.FIRST_COMPLETED)
            if main_task in done:
                exc = None if main_task.cancelled() else main_task.exception()
                if main_task.cancelled():
                    log.error("%s: its body was cancelled", name)
                    print(f"{name}: error: its body was cancelled", file=sys.stderr, flush=True)
                    code = 1
                elif exc is not None:
                    log.error("%s failed: %s", name, exc, exc_info=exc)
                    print(f"{name}: error: {exc}", file=sys.stderr, flush=True)
                    code = 1
                else:
                    print(f"{name}: its body returned; stopping", file=sys.stderr, flush=True)
            else:
                print(f"{name}: stop signal; stopping", file=sys.stderr, flush=True)
        finally:
            stop_task.cancel()
            if not main_task.done():
                main_task.cancel()
                await asyncio.wait({main_task}, timeout=5.0)
            for sig in installed:
                loop.remove_signal_handler(sig)
    return code


def run_module(name: str, main: ModuleMain, net: NetworkConfig, **kw: Any) -> int:
    """Run EDDIE module `name` in a fresh event loop (see `run_module_async`); return the exit code."""
    return asyncio.run(run_module_async(name, main, net, **kw))
