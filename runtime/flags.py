"""The command line every module process shares: one parser maker, the common module flags, one way to parse.

Each entry point (`python -m codger.<name>`, `python -m eddie.<name>`) builds its parser with
`module_parser`, adds what it needs of the common flags (`add_vehicle`, `add_start_pose`, `add_seed`,
`add_heartbeat`) and its own — the shared Zenoh flags (`wire.flags`) come with the parser — and gets its
arguments and network with `parse_module_args`, which sets up logging from SIDEWALK_LOG and exits
through `parser.error` (one line naming the flag) on a bad value.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
from typing import Any, Sequence, TypeVar

from pydantic import BaseModel, ValidationError

from wire.flags import add_network_args, network_from_args
from wire.network import NetworkConfig

__all__ = ["VEHICLES", "module_parser", "add_vehicle", "add_start_pose", "add_seed", "add_heartbeat", "parse_pose",
           "parse_module_args", "setup_logging", "config_flag_errors", "config_from_flags"]

M = TypeVar("M", bound=BaseModel)

#: The vehicles a module can be configured for.
VEHICLES = ("navlab", "terregator")


def setup_logging() -> None:
    """Configure logging from SIDEWALK_LOG (default WARNING) on stderr."""
    logging.basicConfig(
        level=os.environ.get("SIDEWALK_LOG", "WARNING").upper(),
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )


def module_parser(module: str, description: str, *, name: str | None = None) -> argparse.ArgumentParser:
    """Return the parser of `python -m <module>` with `--name` (default `name`, else the package's last part) and the Zenoh flags."""
    p = argparse.ArgumentParser(prog=f"python -m {module}", description=description)
    p.add_argument("--name", default=name or module.rsplit(".", 1)[-1], help="module name (liveliness key chunk, heartbeat)")
    add_network_args(p)
    return p


def add_vehicle(p: argparse.ArgumentParser, *, default: str = "terregator", help: str = "vehicle model") -> None:
    """Add `--vehicle navlab|terregator`."""
    p.add_argument("--vehicle", choices=VEHICLES, default=default, help=help)


def parse_pose(text: str) -> tuple[float, float, float]:
    """Return (x [m], y [m], yaw [rad]) of `X,Y,YAW`; raise ValueError naming what is wrong."""
    parts = text.split(",")
    if len(parts) != 3:
        raise ValueError(f"{text!r}: expected X,Y,YAW")
    try:
        vals = tuple(float(v) for v in parts)
    except ValueError:
        raise ValueError(f"{text!r}: X, Y and YAW must be numbers") from None
    if not all(math.isfinite(v) for v in vals):
        raise ValueError(f"{text!r}: X, Y and YAW must be finite")
    return vals  # type: ignore[return-value]


def _pose_arg(text: str) -> tuple[float, float, float]:
    try:
        return parse_pose(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_start_pose(p: argparse.ArgumentParser, *, default: str | None = "0,0,0", required: bool = False,
                   help: str = "X,Y,YAW: world←local until the navigator says [m, m, rad]") -> None:
    """Add `--start-pose X,Y,YAW`, parsed to (x [m], y [m], yaw [rad]) (None when absent and without a default)."""
    p.add_argument("--start-pose", type=_pose_arg, default=None if required else default, required=required, help=help)


def add_seed(p: argparse.ArgumentParser, *, help: str = "seed of the module's random draws") -> None:
    """Add `--seed N` (default 0)."""
    p.add_argument("--seed", type=int, default=0, help=help)


def add_heartbeat(p: argparse.ArgumentParser) -> None:
    """Add `--heartbeat S`: the heartbeat period [s wall]."""
    p.add_argument("--heartbeat", type=float, default=1.0, help="heartbeat period [s wall]")


def parse_module_args(parser: argparse.ArgumentParser, argv: Sequence[str] | None = None) -> tuple[argparse.Namespace, NetworkConfig]:
    """Parse `argv`, set up logging; return the arguments and the network (exits through `parser.error` on a bad flag)."""
    args = parser.parse_args(argv)
    setup_logging()
    return args, network_from_args(parser, args)


def config_flag_errors(exc, flags: dict[str, str] | None = None) -> str:
    """Return a pydantic ValidationError of a config built from flags as one line naming each flag (`--half-width: …`);
    `flags` maps a field to its flag where the two names differ (default: the field's name with dashes)."""
    def flag(field: str) -> str:
        return (flags or {}).get(field, "--" + field.replace("_", "-"))

    return "; ".join(f"{flag(str(e['loc'][0]))}: {e['msg']}" for e in exc.errors())


def config_from_flags(parser: argparse.ArgumentParser, cls: type[M], values: dict[str, Any]) -> M:
    """Return the pydantic config `cls(**values)` built from flags; a bad value exits through `parser.error`, naming its flag."""
    try:
        return cls(**values)
    except ValidationError as exc:
        parser.error(config_flag_errors(exc))
