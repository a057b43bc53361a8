"""Command-line plumbing shared by the module entry points: the Zenoh flags as argparse options."""

from __future__ import annotations

import argparse
import logging
import os

from pydantic import ValidationError

from blackboard.network import NetworkConfig

__all__ = ["add_network_args", "network_from_args", "setup_logging"]


def add_network_args(parser: argparse.ArgumentParser) -> None:
    """Add `--ns --connect/-e --listen/-l --mode/-m` (same meaning and env vars as the `sidewalk` CLI)."""
    g = parser.add_argument_group("Zenoh")
    g.add_argument("--ns", default=os.environ.get("SIDEWALK_NS", "default"), help="namespace: keys live under sidewalk/<ns>/…")
    g.add_argument("--connect", "-e", action="append", default=None, help="endpoint to connect to (repeatable), e.g. tcp/10.0.0.2:7447")
    g.add_argument("--listen", "-l", action="append", default=None, help="endpoint to listen on (repeatable)")
    g.add_argument("--mode", "-m", default=os.environ.get("SIDEWALK_MODE", "peer"), help="Zenoh mode: peer, client or router")


def network_from_args(parser: argparse.ArgumentParser, args: argparse.Namespace, *, serve: bool = False) -> NetworkConfig:
    """Return the NetworkConfig of parsed flags; exit through `parser.error` naming the bad flag."""
    connect = args.connect if args.connect is not None else [e for e in os.environ.get("SIDEWALK_CONNECT", "").split(",") if e]
    listen = args.listen if args.listen is not None else [e for e in os.environ.get("SIDEWALK_LISTEN", "").split(",") if e]
    try:
        net = NetworkConfig(namespace=args.ns, mode=args.mode, connect=tuple(connect), listen=tuple(listen))
    except ValidationError as exc:
        msgs = "; ".join(f"--{e['loc'][0] if e['loc'] else '?'}: {e['msg']}" for e in exc.errors())
        parser.error(msgs)
    return net.with_defaults(serve=serve)


def setup_logging() -> None:
    """Configure logging from SIDEWALK_LOG (default WARNING) on stderr."""
    logging.basicConfig(
        level=os.environ.get("SIDEWALK_LOG", "WARNING").upper(),
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )
