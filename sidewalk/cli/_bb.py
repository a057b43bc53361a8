"""`sidewalk bb post|retrieve|watch|stats|frames`: talk to a running blackboard from a shell."""

from __future__ import annotations

import asyncio
import json
import sys
from typing import Annotated, Any, Awaitable, Callable, Optional

import typer

from blackboard import BlackboardClient, BlackboardError, NetworkConfig, TypeRegistry
from sidewalk.json_out import dumps
from wire.flags import with_network

__all__ = ["bb_app"]

bb_app = typer.Typer(help="Post, retrieve and watch blackboard tokens (JSON in, JSON lines out).", no_args_is_help=True)


def _json_arg(text: str, what: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise typer.BadParameter(f"{what} is not valid JSON: {exc}") from None


def _run(net: NetworkConfig, timeout: float, body: Callable[[BlackboardClient], Awaitable[None]]) -> None:
    async def main() -> None:
        async with BlackboardClient(net, source="cli", registry=TypeRegistry(), lenient=True, timeout=timeout, connect_timeout=timeout) as bb:
            await body(bb)

    try:
        asyncio.run(main())
    except BlackboardError as exc:
        typer.echo(f"error: {exc.code}: {exc}", err=True)
        raise typer.Exit(1) from None
    except KeyboardInterrupt:
        raise typer.Exit(130) from None


def _line(obj: Any) -> None:
    sys.stdout.write(dumps(obj, sort_keys=True) + "\n")
    sys.stdout.flush()


@bb_app.command("post")
@with_network()
def post_cmd(
    net: NetworkConfig,
    type: Annotated[str, typer.Argument(help="Registered token type")],
    attrs: Annotated[str, typer.Argument(help="Attributes as a JSON object")],
    frame: Annotated[str, typer.Option(help="Frame of the geometry")] = "world",
    stamp: Annotated[float, typer.Option(help="Sim time [s]")] = 0.0,
    geometry: Annotated[Optional[str], typer.Option(help='Geometry JSON, e.g. {"kind":"point","x":1,"y":2}')] = None,
    timeout: Annotated[float, typer.Option(help="Give up after [s]")] = 10.0,
) -> None:
    """Post one token; print it as a JSON line."""
    a = _json_arg(attrs, "JSON")
    g = _json_arg(geometry, "--geometry") if geometry else None

    async def body(bb: BlackboardClient) -> None:
        _line(await bb.post_raw(type, a, frame=frame, geometry=g, stamp=stamp))

    _run(net, timeout, body)


@bb_app.command("retrieve")
@with_network()
def retrieve_cmd(
    net: NetworkConfig,
    spec: Annotated[str, typer.Argument(help='Spec as JSON, e.g. {"type":"route_segment","limit":5}')],
    frame: Annotated[Optional[str], typer.Option("--frame", help="Express geometry in this frame")] = None,
    stamp: Annotated[Optional[float], typer.Option("--stamp", help="Time of --frame [s] (default: each token's stamp)")] = None,
    timeout: Annotated[float, typer.Option(help="Give up after [s]")] = 10.0,
) -> None:
    """Retrieve the tokens matching a spec; print one JSON line per token."""
    s = _json_arg(spec, "SPEC_JSON")

    async def body(bb: BlackboardClient) -> None:
        for tok in await bb.retrieve_raw(s, frame=frame, frame_stamp=stamp):
            _line(tok)

    _run(net, timeout, body)


@bb_app.command("watch")
@with_network()
def watch_cmd(
    net: NetworkConfig,
    spec: Annotated[str, typer.Argument(help="Spec as JSON ({} for everything)")],
    count: Annotated[int, typer.Option(help="Stop after this many events (0: until Ctrl-C)")] = 0,
    timeout: Annotated[float, typer.Option(help="Connection timeout [s]")] = 10.0,
) -> None:
    """Print one JSON line {"kind", "token"} per new/updated/deleted token matching a spec."""
    s = _json_arg(spec, "SPEC_JSON")
    from blackboard.spec import parse_spec

    try:
        parsed = parse_spec(s)
    except BlackboardError as exc:
        raise typer.BadParameter(str(exc)) from None

    async def body(bb: BlackboardClient) -> None:
        n = 0
        async with bb.monitor(parsed) as mon:
            typer.echo("watching", err=True)
            async for ev in mon:
                tok = ev.token
                attrs = tok.attrs if isinstance(tok.attrs, dict) else tok.attrs.model_dump(mode="json")
                _line({"kind": ev.kind, "token": {**tok.model_dump(mode="json", exclude={"attrs"}), "attrs": attrs}})
                n += 1
                if count and n >= count:
                    return

    _run(net, timeout, body)


@bb_app.command("stats")
@with_network()
def stats_cmd(net: NetworkConfig, timeout: Annotated[float, typer.Option(help="Give up after [s]")] = 10.0) -> None:
    """Print the node's counters as one JSON line."""

    async def body(bb: BlackboardClient) -> None:
        _line((await bb.stats()).model_dump())

    _run(net, timeout, body)


@bb_app.command("frames")
@with_network()
def frames_cmd(net: NetworkConfig, timeout: Annotated[float, typer.Option(help="Give up after [s]")] = 10.0) -> None:
    """Print the node's frame tree as one JSON line."""

    async def body(bb: BlackboardClient) -> None:
        _line((await bb.frames()).wire())

    _run(net, timeout, body)
