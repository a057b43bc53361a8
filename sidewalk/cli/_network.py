"""The one set of Zenoh flags (`--ns --connect --listen --mode`) every command shares."""

from __future__ import annotations

import functools
import inspect
from typing import Annotated, Any, Callable, Optional

import typer
from pydantic import ValidationError

from blackboard.network import NetworkConfig

__all__ = ["with_network"]

_PARAMS = [
    inspect.Parameter(
        "ns",
        inspect.Parameter.KEYWORD_ONLY,
        default="default",
        annotation=Annotated[str, typer.Option("--ns", help="Namespace: keys live under sidewalk/<ns>/…", envvar="SIDEWALK_NS", rich_help_panel="Zenoh")],
    ),
    inspect.Parameter(
        "connect",
        inspect.Parameter.KEYWORD_ONLY,
        default=None,
        annotation=Annotated[Optional[list[str]], typer.Option("--connect", "-e", help="Endpoint to connect to (repeatable), e.g. tcp/10.0.0.2:7447", envvar="SIDEWALK_CONNECT", rich_help_panel="Zenoh")],
    ),
    inspect.Parameter(
        "listen",
        inspect.Parameter.KEYWORD_ONLY,
        default=None,
        annotation=Annotated[Optional[list[str]], typer.Option("--listen", "-l", help="Endpoint to listen on (repeatable)", envvar="SIDEWALK_LISTEN", rich_help_panel="Zenoh")],
    ),
    inspect.Parameter(
        "mode",
        inspect.Parameter.KEYWORD_ONLY,
        default="peer",
        annotation=Annotated[str, typer.Option("--mode", "-m", help="Zenoh mode: peer, client or router", envvar="SIDEWALK_MODE", rich_help_panel="Zenoh")],
    ),
]


def with_network(*, serve: bool = False) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Add the shared Zenoh flags to a command and pass them as `net: NetworkConfig`.

    `serve=True` commands listen on the default endpoint when none is given; the others connect to it.
    """

    def decorate(fn: Callable[..., Any]) -> Callable[..., Any]:
        sig = inspect.signature(fn, eval_str=True)
        params = [p for name, p in sig.parameters.items() if name != "net"]

        @functools.wraps(fn)
        def wrapper(*args: Any, ns: str, connect: list[str] | None, listen: list[str] | None, mode: str, **kwargs: Any) -> Any:
            try:
                net = NetworkConfig(namespace=ns, mode=mode, connect=tuple(connect or ()), listen=tuple(listen or ()))
            except ValidationError as exc:
                msgs = "; ".join(f"--{e['loc'][0] if e['loc'] else '?'}: {e['msg']}" for e in exc.errors())
                raise typer.BadParameter(msgs) from None
            return fn(*args, net=net.with_defaults(serve=serve), **kwargs)

        new_sig = sig.replace(parameters=params + _PARAMS)
        wrapper.__signature__ = new_sig  # type: ignore[attr-defined]
        # evaluated annotations: Typer resolves hints in the wrapper's globals, not the command's
        wrapper.__annotations__ = {p.name: p.annotation for p in new_sig.parameters.values()}
        if new_sig.return_annotation is not inspect.Signature.empty:
            wrapper.__annotations__["return"] = new_sig.return_annotation
        del wrapper.__wrapped__
        return wrapper

    return decorate
