"""`python -m blackboard --listen tcp/127.0.0.1:7447 --db bb.sqlite --types pkg.mod`: run a node.

The `sidewalk blackboard serve` command is the usual way; this entry point lets launchers and
tests start a node without the sidewalk package.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys

from wire.flags import add_network_args, network_from_args
from blackboard.node import serve

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Parse arguments and serve until SIGINT/SIGTERM."""
    ap = argparse.ArgumentParser(prog="python -m blackboard", description="Run a CODGER blackboard node.")
    add_network_args(ap)
    ap.add_argument("--db", default=":memory:", help="SQLite file, or :memory:")
    ap.add_argument("--sync", default="normal", choices=["normal", "full"], help="normal: survives crashes; full: power loss")
    ap.add_argument("--types", action="append", default=[], help="module registering token types (repeatable)")
    ap.add_argument("--dispatch", default="inline", choices=["inline", "loop"], help="where requests are processed (see blackboard.node)")
    ap.add_argument("--history", type=float, default=60.0, help="pose history kept [s]")
    ap.add_argument("--test-hold-after-journal", metavar="PATH", default=None,
                    help="durability tests only: after a commit's journal append, while PATH exists, "
                         "create PATH.held and hold before acknowledging")
    a = ap.parse_args(argv)
    logging.basicConfig(level=os.environ.get("SIDEWALK_LOG", "WARNING").upper())
    net = network_from_args(ap, a, role="peer")
    serve(net, db=a.db, sync=a.sync, types=tuple(a.types), history=a.history, dispatch=a.dispatch,
          test_hold_after_journal=a.test_hold_after_journal)
    return 0


if __name__ == "__main__":
    sys.exit(main())
