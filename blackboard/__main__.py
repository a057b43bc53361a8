"""`python -m blackboard --listen tcp/127.0.0.1:7447 --db bb.sqlite --types pkg.mod`: run a node.

The `sidewalk blackboard serve` command is the usual way; this entry point lets launchers and
tests start a node without the sidewalk package.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys

from blackboard.network import NetworkConfig
from blackboard.node import serve

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Parse arguments and serve until SIGINT/SIGTERM."""
    ap = argparse.ArgumentParser(prog="python -m blackboard", description="Run a CODGER blackboard node.")
    ap.add_argument("--ns", default="default", help="namespace: keys under sidewalk/<ns>/…")
    ap.add_argument("--listen", action="append", default=[], help="endpoint to listen on (repeatable)")
    ap.add_argument("--connect", action="append", default=[], help="endpoint to connect to (repeatable)")
    ap.add_argument("--mode", default="peer", choices=["peer", "client", "router"])
    ap.add_argument("--db", default=":memory:", help="SQLite file, or :memory:")
    ap.add_argument("--sync", default="normal", choices=["normal", "full"], help="normal: survives crashes; full: power loss")
    ap.add_argument("--types", action="append", default=[], help="module registering token types (repeatable)")
    ap.add_argument("--dispatch", default="inline", choices=["inline", "loop"], help="where requests are processed (see blackboard.node)")
    ap.add_argument("--history", type=float, default=60.0, help="pose history kept [s]")
    a = ap.parse_args(argv)
    logging.basicConfig(level=os.environ.get("SIDEWALK_LOG", "WARNING").upper())
    try:
        net = NetworkConfig(namespace=a.ns, mode=a.mode, connect=tuple(a.connect), listen=tuple(a.listen)).with_defaults(serve=True)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    serve(net, db=a.db, sync=a.sync, types=tuple(a.types), history=a.history, dispatch=a.dispatch)
    return 0


if __name__ == "__main__":
    sys.exit(main())
