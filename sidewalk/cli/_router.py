"""`sidewalk router serve` (also `sidewalk up router`): the system's Zenoh router."""

# No `from __future__ import annotations`: `with_network` copies the signature without evaluating it.
import os
import signal
import sys
import threading

import typer

from wire.errors import WireError
from wire.flags import with_network
from wire.lifeline import dump_stacks_on_request
from wire.network import NetworkConfig

__all__ = ["router_app"]

router_app = typer.Typer(help="The system's Zenoh router: every peer and tool connects to it.", no_args_is_help=True)


@router_app.command("serve")
@with_network("router")
def serve(*, net: NetworkConfig) -> None:
    """Run the router until SIGINT/SIGTERM; prints "router ready …" once listening (default tcp/127.0.0.1:7447)."""
    from wire.router import serve_router

    if net.secure is not None:  # the router enforces DIR/rules.yaml: regenerate its access control at each start
        from sidewalk.security import SecurityError, access_control_json

        try:
            acl = access_control_json(net.secure.dir)
        except SecurityError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2) from None
        net = net.model_copy(update={"secure": net.secure.model_copy(update={"access_control": acl})})
    stop = threading.Event()
    old = {s: signal.signal(s, lambda *_: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    dump_stacks_on_request()  # `kill -USR1` prints where a stuck router is
    try:
        if not serve_router(net, stop):
            print("router: its Zenoh session did not close within 5 s; exiting without it (a router keeps no state)",
                  file=sys.stderr, flush=True)
            os._exit(0)  # an interpreter exit would wait for the session's threads
    except WireError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(3) from None
    finally:
        for s, h in old.items():
            signal.signal(s, h)
