"""`python -m eddie.toolkit.echo NAME`: a module that answers `echo` requests and echoes its inbox back to the sender.

A diagnostic for a system's links (is module NAME reachable, how long does a round trip take); the
toolkit's tests and benchmarks run it as a real process.
"""

from __future__ import annotations

import sys

from runtime import module_parser, parse_module_args, run_module

from eddie.errors import BadMessage
from eddie.toolkit.message import Message, message_type
from eddie.toolkit.module import Incoming, Module, endpoint

__all__ = ["Echo", "main"]


@message_type("toolkit.echo")
class Echo(Message):
    """An echo request or reply: a sequence number and opaque bytes."""

    seq: int = 0
    data: bytes = b""


def main(argv: list[str] | None = None) -> int:
    """Run an echo module named by the first argument."""
    ap = module_parser("eddie.toolkit.echo", __doc__.splitlines()[0], name="echo")
    ap.add_argument("module", nargs="?", default=None, help="module name (as --name)")
    args, net = parse_module_args(ap, argv)

    async def body(m: Module) -> None:
        async def echo(inc: Incoming) -> Message:
            return inc.message

        m.serve("echo", echo)
        m.ready()
        while True:
            try:
                inc = await m.receive()
            except BadMessage:
                continue
            await m.send(inc.sender, inc.message)

    return run_module(args.module or args.name, endpoint(body), net)


if __name__ == "__main__":
    sys.exit(main())
