"""A vision worker process: maps the host's shared frame, runs stripe operators and chunk functions on request.

Messages over its pipe (host → worker): ("stripe", op, block name, input refs, output refs, params,
stripe) runs `op` on that stripe of the shared frame and writes the output cores in place;
("chunk", fn, items, params) returns fn(items, params); ("task", fn, block name, refs, args) returns
fn(the arrays `refs` names, as views of the shared frame, args); None ends the worker. Replies: ("ok", value)
or ("error", one line). The worker also ends when the host's end of the pipe closes (the host died).
"""

from __future__ import annotations

import importlib
import os
import signal
from multiprocessing.connection import Connection
from multiprocessing.shared_memory import SharedMemory
from typing import Sequence

from modules.parallel.intra_threads import limit_intra_threads
from modules.parallel.shared_frame import attach, view
from modules.parallel.stripe_op import run_stripe

__all__ = ["serve"]


def serve(conn: Connection, warm: Sequence[str] = (), intra_threads: int | None = None) -> None:
    """Serve the host on `conn` until told to stop or the host is gone; import `warm` modules first, then let the
    libraries use `intra_threads` threads inside one operation (None: their own choice)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C is the host's to handle; the host then closes the pipe
    for name in warm:
        importlib.import_module(name)
    if intra_threads is not None:
        limit_intra_threads(intra_threads)
    conn.send(("ready", os.getpid()))
    blocks: dict[str, SharedMemory] = {}
    try:
        while True:
            try:
                msg = conn.recv()
            except (EOFError, OSError):
                return
            if msg is None:
                return
            try:
                conn.send(("ok", _do(msg, blocks)))
            except Exception as exc:  # the host raises it as a WorkerError; the worker serves on
                conn.send(("error", f"{type(exc).__name__}: {exc}".splitlines()[0][:500]))
    finally:
        _close(blocks)


def _close(blocks: dict[str, SharedMemory]) -> None:
    for shm in blocks.values():
        try:
            shm.close()
        except BufferError:  # an operator kept a view; the mapping goes with the process
            pass
    blocks.clear()


def _block(name: str, blocks: dict[str, SharedMemory]) -> SharedMemory:
    """Return the host's block `name`, mapped once (the host grew its block when the name changes: the old one is gone)."""
    if name not in blocks:
        _close(blocks)
        blocks[name] = attach(name)
    return blocks[name]


def _do(msg: tuple, blocks: dict[str, SharedMemory]):
    kind = msg[0]
    if kind == "chunk":
        _, fn, items, params = msg
        return fn(items, params)
    if kind == "task":
        _, fn, name, refs, args = msg
        buf = _block(name, blocks).buf
        return fn({k: view(buf, r) for k, r in refs.items()}, args)
    if kind != "stripe":
        raise ValueError(f"unknown request {kind!r}")
    _, op, name, in_refs, out_refs, params, stripe = msg
    buf = _block(name, blocks).buf
    inputs = {k: view(buf, r) for k, r in in_refs.items()}
    outputs = {k: view(buf, r) for k, r in out_refs.items()}
    run_stripe(op, inputs, outputs, params, stripe)
    return None
