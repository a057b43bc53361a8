"""`sidewalk blackboard serve`: run the CODGER blackboard node."""

from __future__ import annotations

from typing import Annotated, Optional

import typer

from wire.network import NetworkConfig
from wire.flags import with_network

__all__ = ["blackboard_app"]

blackboard_app = typer.Typer(help="The CODGER blackboard node.", no_args_is_help=True)


@blackboard_app.command("serve")
@with_network("peer", who="blackboard")
def serve_cmd(
    net: NetworkConfig,
    db: Annotated[str, typer.Option("--db", help="SQLite database file, or :memory: for a throwaway store")] = ":memory:",
    types: Annotated[Optional[list[str]], typer.Option("--types", help="Module whose @token_type models to register (repeatable; default: the Sidewalk vocabulary, modules.vocabulary)")] = None,
    sync: Annotated[str, typer.Option("--sync", help="normal: acknowledged writes survive a crash/SIGKILL; full: also power loss (fsync per commit)")] = "normal",
    history: Annotated[float, typer.Option("--history", help="Pose history kept per moving frame [s]")] = 60.0,
    dispatch: Annotated[str, typer.Option("--dispatch", help="inline: answer in the zenoh callback (fast); loop: hand every request to the asyncio loop")] = "inline",
) -> None:
    """Serve the blackboard until SIGINT/SIGTERM; prints one "blackboard ready …" line when serving."""
    from blackboard.errors import StoreOpenError
    from blackboard.node import serve

    if sync not in ("normal", "full"):
        raise typer.BadParameter(f"--sync must be 'normal' or 'full', not {sync!r}")
    if dispatch not in ("inline", "loop"):
        raise typer.BadParameter(f"--dispatch must be 'inline' or 'loop', not {dispatch!r}")
    if history <= 0:
        raise typer.BadParameter("--history must be > 0 [s]")
    try:
        serve(net, db=db, sync=sync, types=tuple(types or ("modules.vocabulary",)), history=history, dispatch=dispatch)  # type: ignore[arg-type]
    except ImportError as exc:
        raise typer.BadParameter(str(exc), param_hint="--types") from None
    except StoreOpenError as exc:  # e.g. the database is held by another node: one line, no traceback
        raise typer.BadParameter(exc.message, param_hint="--db") from None
