"""The `sidewalk` command line: one Typer app, one sub-app per area, each in its own file."""

from __future__ import annotations

import importlib
import logging
import os
import sys

import typer

__all__ = ["app", "main"]

app = typer.Typer(
    name="sidewalk",
    help="Sidewalk: the CMU Terregator/Navlab navigation stack on a Zenoh CODGER blackboard.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)

# (module, attribute, name) — each area registers its commands in its own file.
_SUBAPPS = [
    ("sidewalk.cli._router", "router_app", "router"),
    ("sidewalk.cli._blackboard", "blackboard_app", "blackboard"),
    ("sidewalk.cli._bb", "bb_app", "bb"),
    ("sidewalk.cli._sim", "sim_app", "sim"),
    ("sidewalk.cli._bench", "bench_app", "bench"),
    ("sidewalk.cli._perception", "perception_app", "perception"),
    ("sidewalk.cli._security", "security_app", "security"),
    ("sidewalk.cli._eddie", "eddie_app", "eddie"),
    ("sidewalk.cli._roadfollow", "roadfollow_app", "roadfollow"),
    ("sidewalk.cli._terrain", "terrain_app", "terrain"),
]
_COMMANDS = [
    ("sidewalk.cli._run", "register"),
    ("sidewalk.cli._monitor", "register"),
    ("sidewalk.cli._mapbuild", "register"),
    ("sidewalk.cli._compare", "register"),
    ("sidewalk.cli._worldgen", "register"),
]


def _assemble() -> None:
    for modname, attr, name in _SUBAPPS:
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name == modname:
                continue
            raise
        app.add_typer(getattr(mod, attr), name=name)
    for modname, attr in _COMMANDS:
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name == modname:
                continue
            raise
        getattr(mod, attr)(app)


_assemble()


def main() -> None:
    """Run the CLI with logging set from SIDEWALK_LOG (default WARNING)."""
    logging.basicConfig(
        level=os.environ.get("SIDEWALK_LOG", "WARNING").upper(),
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
    )
    from wire.errors import WireError

    try:
        code = app(standalone_mode=False)
    except WireError as exc:  # e.g. no router at the endpoint: one line, no traceback
        print(f"error: {_one_line(str(exc))}", file=sys.stderr)
        sys.exit(3)
    except typer.TyperException as exc:  # a bad flag or argument: one line naming it, and where to read more
        ctx = getattr(exc, "ctx", None)
        where = f" (see `{ctx.command_path} --help`)" if ctx is not None else ""
        print(f"error: {_one_line(exc.format_message())}{where}", file=sys.stderr)
        sys.exit(exc.exit_code)
    except (typer.Abort, KeyboardInterrupt):
        print("interrupted", file=sys.stderr)
        sys.exit(130)
    sys.exit(code if isinstance(code, int) else 0)


def _one_line(text: str, limit: int = 400) -> str:
    """Return `text` on one line, cut to `limit` characters."""
    flat = " ".join(text.split())
    return flat if len(flat) <= limit else flat[:limit] + "…"
