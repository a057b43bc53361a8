"""The one set of Zenoh flags every Sidewalk command shares: `--ns --connect --listen --mode --secure --role --lease`.

Defined once (`FLAGS`) and offered to both command-line front ends: Typer (`with_network`, the
`sidewalk` CLI) and argparse (`add_network_args` / `network_from_args`, the module entry points).
Each flag has an environment variable. The default mode depends on the command's role: a `router`
listens; a `peer` (modules, the blackboard node, the simulator, the recorder, the monitor) is a
client of the router it connects to, and a Zenoh peer only when it listens itself (`--listen`:
others connect to it); a `tool` (status, submit, cancel, bb …) is a client of the router.

Why clients: peers linked to one another directly (learnt through the router's gossip) lose those
links when one of them stops past its lease, and a peer up all the while may never hear the other
again once it continues (eclipse-zenoh/zenoh#498). Through the router, the router re-declares
everything to the returning client, at the cost of one hop. `--mode peer` still gives direct links.

`--secure DIR` (see docs/security.md) switches the session to mutual TLS with a user/password and
makes every process a client of the router, whose access control enforces DIR/rules.yaml. The
process's identity there is its role: the command's (`who`: `helm`, `sim`, `monitor`, `router`…;
`operator` for tools), overridden by `--role`.
"""

from __future__ import annotations

import argparse
import functools
import inspect
import os
from dataclasses import dataclass
from typing import Annotated, Any, Callable, Literal, Optional

from pydantic import ValidationError

from pathlib import Path

from wire.network import NetworkConfig, SecureConfig, check_chunk
from wire.errors import WireError

__all__ = ["FLAGS", "Flag", "Role", "network_config", "with_network", "add_network_args", "network_from_args"]

Role = Literal["router", "peer", "tool"]

_ROLE_MODE = {"router": "router", "peer": "client", "tool": "client"}


@dataclass(frozen=True)
class Flag:
    """One shared flag: its name, short form, environment variable, help, and whether it repeats."""

    name: str
    short: str
    env: str
    help: str
    repeat: bool = False


#: The shared flags, in the order they are shown.
FLAGS: tuple[Flag, ...] = (
    Flag("ns", "", "SIDEWALK_NS", "Namespace: keys live under sidewalk/<ns>/… (default: default)"),
    Flag("connect", "-e", "SIDEWALK_CONNECT", "Endpoint to connect to (repeatable), e.g. tcp/10.0.0.2:7447 (default: tcp/127.0.0.1:7447)", True),
    Flag("listen", "-l", "SIDEWALK_LISTEN", "Endpoint to listen on (repeatable)", True),
    Flag("mode", "-m", "SIDEWALK_MODE", "Zenoh mode: peer, client or router (default: by command — router for `up router`, peer for a process that listens, client otherwise)"),
    Flag("secure", "", "SIDEWALK_SECURE", "Secure directory from `sidewalk security init`: mutual TLS, password and the router's access control"),
    Flag("role", "", "", "Identity under --secure (default: the command's — helm, sim, monitor, router…; operator for tools)"),
    Flag("lease", "", "SIDEWALK_LEASE", "Zenoh lease [s] this process announces: how long it may stay silent (stopped, cut off) "
         "before the others drop it (default: Zenoh's 10)"),
)

#: The flag of each NetworkConfig field whose name differs from it (for errors).
_FLAG_OF = {"lease_s": "lease", "namespace": "ns"}

#: The identity a command has under --secure when it names none: tools act for the operator.
_ROLE_WHO = {"router": "router", "tool": "operator"}


class FlagError(WireError, ValueError):
    """A bad value for one of the shared flags (the message names the flag)."""


def network_config(*, ns: str | None, connect: list[str] | None, listen: list[str] | None, mode: str | None,
                   role: Role, secure: str | None = None, who: str | None = None, lease: str | None = None) -> NetworkConfig:
    """Return the NetworkConfig of parsed flag values (None = not given: environment, then default); raise FlagError.

    `who` is the identity under --secure (the --role flag, else the command's own name); `lease` [s] as given.
    """
    env = os.environ
    lease = lease if lease is not None else env.get("SIDEWALK_LEASE") or None
    try:
        lease_s = None if lease is None else float(lease)
    except ValueError:
        raise FlagError(f"--lease {lease!r}: wants seconds, e.g. 3") from None
    secure = secure if secure is not None else env.get("SIDEWALK_SECURE") or None
    sec = None
    if secure:
        who = who or _ROLE_WHO.get(role)
        if not who:
            raise FlagError("--role: this command has no default identity under --secure; name one with --role")
        try:
            sec = SecureConfig(dir=Path(secure).expanduser(), role=check_chunk(who, "--role"))
        except (ValidationError, ValueError) as exc:
            raise FlagError(f"--role: {exc}") from None
    ns = ns if ns is not None else env.get("SIDEWALK_NS", "default")
    if connect is None:
        connect = [e for e in env.get("SIDEWALK_CONNECT", "").split(",") if e]
    if listen is None:
        listen = [e for e in env.get("SIDEWALK_LISTEN", "").split(",") if e]
    if mode is None:
        mode = env.get("SIDEWALK_MODE") or ("peer" if role == "peer" and listen else _ROLE_MODE[role])
    try:
        net = NetworkConfig(namespace=ns, mode=mode, connect=tuple(connect), listen=tuple(listen), secure=sec, lease_s=lease_s)
    except ValidationError as exc:
        msgs = "; ".join(f"--{_FLAG_OF.get(e['loc'][0], e['loc'][0]) if e['loc'] else 'connect/listen'}: {e['msg']}".replace("Value error, ", "")
                         for e in exc.errors())
        raise FlagError(msgs) from None
    net = net.with_defaults()
    if net.secure is not None:
        hosts = tuple(_listen_host(ep) for ep in net.listen)
        problems = net.secure.problems(hosts)
        if problems:
            raise FlagError(problems[0])
    return net


def _listen_host(endpoint: str) -> str:
    addr = endpoint.partition("/")[2].split("#", 1)[0]
    return (addr.rsplit(":", 1)[0] if ":" in addr else addr).strip("[]")


# ---- Typer --------------------------------------------------------------------------------------

def _typer_params() -> list[inspect.Parameter]:
    import typer

    out = []
    for f in FLAGS:
        names = [f"--{f.name}"] + ([f.short] if f.short else [])
        annotation = Optional[list[str]] if f.repeat else Optional[str]
        out.append(inspect.Parameter(
            f.name, inspect.Parameter.KEYWORD_ONLY, default=None,
            annotation=Annotated[annotation, typer.Option(*names, help=f.help, rich_help_panel="Zenoh")],
        ))
    return out


def with_network(role: Role = "tool", who: str | None = None) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Add the shared Zenoh flags to a Typer command and pass them as `net: NetworkConfig` (`who`: its --secure identity)."""
    import typer

    kind = role

    def decorate(fn: Callable[..., Any]) -> Callable[..., Any]:
        sig = inspect.signature(fn, eval_str=True)
        params = [p for name, p in sig.parameters.items() if name != "net"]

        @functools.wraps(fn)
        def wrapper(*args: Any, ns: str | None, connect: list[str] | None, listen: list[str] | None, mode: str | None,
                    secure: str | None, role: str | None, lease: str | None, **kwargs: Any) -> Any:
            try:
                net = network_config(ns=ns, connect=connect, listen=listen, mode=mode, role=kind, secure=secure,
                                     who=role or who, lease=lease)
            except FlagError as exc:
                raise typer.BadParameter(str(exc)) from None
            return fn(*args, net=net, **kwargs)

        new_sig = sig.replace(parameters=params + _typer_params())
        wrapper.__signature__ = new_sig  # type: ignore[attr-defined]
        # evaluated annotations: Typer resolves hints in the wrapper's globals, not the command's
        wrapper.__annotations__ = {p.name: p.annotation for p in new_sig.parameters.values()}
        if new_sig.return_annotation is not inspect.Signature.empty:
            wrapper.__annotations__["return"] = new_sig.return_annotation
        del wrapper.__wrapped__
        return wrapper

    return decorate


# ---- argparse -----------------------------------------------------------------------------------

def add_network_args(parser: argparse.ArgumentParser) -> None:
    """Add the shared flags to an argparse parser (same names, short forms and environment variables)."""
    g = parser.add_argument_group("Zenoh")
    for f in FLAGS:
        names = [f"--{f.name}"] + ([f.short] if f.short else [])
        g.add_argument(*names, action="append" if f.repeat else "store", default=None, help=f.help)


def network_from_args(parser: argparse.ArgumentParser, args: argparse.Namespace, *, role: Role = "peer",
                      who: str | None = None) -> NetworkConfig:
    """Return the NetworkConfig of parsed flags; exit through `parser.error` naming the bad flag.

    The --secure identity is --role, else `who`, else the program's module (`python -m codger.helm` → helm,
    `python -m eddie.obstacle_stop.obstacle_stop_module` → obstacle_stop).
    """
    if who is None and parser.prog.startswith("python -m "):
        # the last dotted part that is not `__main__`, without a `_module` suffix (eddie.obstacle_stop.obstacle_stop_module → obstacle_stop)
        parts = [p for p in parser.prog.rsplit(" ", 1)[-1].split(".") if p != "__main__"]
        who = parts[-1].removesuffix("_module") if parts else None
    try:
        return network_config(ns=args.ns, connect=args.connect, listen=args.listen, mode=args.mode, role=role,
                              secure=args.secure, who=args.role or who, lease=args.lease)
    except FlagError as exc:
        parser.error(str(exc))
        raise  # parser.error exits
