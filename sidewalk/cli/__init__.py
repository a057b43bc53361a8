"""The `sidewalk` command line: one Typer app, one sub-app per area, each in its own file, imported when used.

Every command's file is imported only when that command runs (or its own `--help` is asked for): the
top-level app lists the commands from `COMMANDS` without importing them, so `sidewalk --help` and a
quick `sidewalk status` do not pay for numpy, the pydantic models or the blackboard client.
"""

from __future__ import annotations

import importlib
import importlib.util
import logging
import os
import sys
from typing import Any, NamedTuple

import typer
from typer.core import TyperCommand, TyperGroup

__all__ = ["app", "main", "COMMANDS", "LazyCommand"]


class LazyCommand(NamedTuple):
    """One top-level command: its name, the file that defines it, how, and its one-line help.

    `attr` is a Typer sub-app in `module` (`router_app`…), or `register`: a function that adds the
    module's commands to an app. `help` is what `sidewalk --help` lists before the module is imported
    (tests/sidewalk/test_cli_startup.py holds it equal to the command's own help).
    """

    name: str
    module: str
    attr: str
    help: str


#: The top-level commands, in the order `sidewalk --help` lists them.
COMMANDS: tuple[LazyCommand, ...] = (
    LazyCommand("run", "sidewalk.cli._run", "register",
                "Run a mission as OS processes on loopback Zenoh (CODGER: blackboard and modules; --arch eddie: EDDIE, no "
                "blackboard); writes run.mcap."),
    LazyCommand("up", "sidewalk.cli._run", "register",
                "Run one part of the system on this host; the rest of the arguments go to it (try `up pilot --help`)."),
    LazyCommand("submit", "sidewalk.cli._run", "register", "Send a mission to the CAPTAIN over Zenoh and follow its progress."),
    LazyCommand("status", "sidewalk.cli._run", "register",
                "List the live modules (liveliness, heartbeat age, wedged ones) and the missions the CAPTAIN knows."),
    LazyCommand("cancel", "sidewalk.cli._run", "register", "Cancel a running mission."),
    LazyCommand("monitor", "sidewalk.cli._monitor", "register",
                "Serve the NAVIGATION MONITOR: a live page of the map, route, driving units, poses, paths and module health."),
    LazyCommand("replay", "sidewalk.cli._monitor", "register",
                "Play a recording back into the NAVIGATION MONITOR page at `--speed` times sim speed."),
    LazyCommand("record", "sidewalk.cli._monitor", "register",
                "Record every message of a live system into an MCAP file until Ctrl-C (what every `sidewalk run` does)."),
    LazyCommand("mapbuild", "sidewalk.cli._mapbuild", "register",
                "Drive a route by the robot's own estimate from the map's start, track what the laser sees, write a map a later run can use (--map)."),
    LazyCommand("compare", "sidewalk.cli._compare", "register",
                "Run every mission × seed × architecture (and faults, speed sweep) as `sidewalk run` processes; write tables "
                "and plots."),
    LazyCommand("worldgen", "sidewalk.cli._worldgen", "register",
                "Generate a world of KIND from a seed: the world and its map (with their terrain rasters) and a mission across it."),
    LazyCommand("compare-check", "sidewalk.cli._compare", "register",
                "Hold two grids of the same command against each other: does each median lie within the other's range? Exit 1 "
                "if not."),
    LazyCommand("router", "sidewalk.cli._router", "router_app", "The system's Zenoh router: every peer and tool connects to it."),
    LazyCommand("blackboard", "sidewalk.cli._blackboard", "blackboard_app", "The CODGER blackboard node."),
    LazyCommand("bb", "sidewalk.cli._bb", "bb_app", "Post, retrieve and watch blackboard tokens (JSON in, JSON lines out)."),
    LazyCommand("sim", "sidewalk.cli._sim", "sim_app", "The Terregator/Navlab simulator: world, vehicle, sensors."),
    LazyCommand("bench", "sidewalk.cli._bench", "bench_app", "Benchmarks; each prints one JSON object."),
    LazyCommand("perception", "sidewalk.cli._perception", "perception_app",
                "PERCEPTION: colored-range segmentation, object finding, position fixes."),
    LazyCommand("security", "sidewalk.cli._security", "security_app",
                "Secure deployments: certificates, passwords and access rules (see docs/security.md)."),
    LazyCommand("eddie", "sidewalk.cli._eddie", "eddie_app", "EDDIE: annotated maps (compile a mission into triggers, inspect a file)."),
    LazyCommand("roadfollow", "sidewalk.cli._roadfollow", "roadfollow_app",
                "Road following as the Navlab did it: SCARF, YARF, ALVINN (data set, training, evaluation)."),
    LazyCommand("terrain", "sidewalk.cli._terrain", "terrain_app", "Terrain from the laser: elevation maps scored against the truth raster."),
)
_BY_NAME = {c.name: c for c in COMMANDS}


class _Listed(TyperCommand):
    """A command as `--help` lists it: its name and one-line help, its module not imported."""


def _installed(modname: str) -> bool:
    """Return whether `modname` can be imported (an installation may leave an area out)."""
    try:
        return importlib.util.find_spec(modname) is not None
    except ModuleNotFoundError:
        return False


def load_command(name: str) -> Any:
    """Import the file of top-level command `name` and return its click command (a group for a sub-app)."""
    entry = _BY_NAME[name]
    carrier = typer.Typer(add_completion=False)
    target = getattr(importlib.import_module(entry.module), entry.attr)
    if isinstance(target, typer.Typer):
        carrier.add_typer(target, name=name)
    else:
        target(carrier)
    return typer.main.get_group(carrier).commands[name]


class _LazyGroup(TyperGroup):
    """The top-level group: lists `COMMANDS` without importing them; imports one when it is invoked."""

    def list_commands(self, ctx: Any) -> list[str]:
        return [c.name for c in COMMANDS if _installed(c.module)]

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        entry = _BY_NAME.get(cmd_name)
        if entry is None or not _installed(entry.module):
            return None
        if cmd_name not in self.commands:
            self.commands[cmd_name] = _Listed(name=cmd_name, help=entry.help)
        return self.commands[cmd_name]

    def resolve_command(self, ctx: Any, args: list[str]) -> tuple[str | None, Any, list[str]]:
        self.commands.update((n, self.get_command(ctx, n)) for n in self.list_commands(ctx) if n not in self.commands)
        name, cmd, rest = super().resolve_command(ctx, args)
        if isinstance(cmd, _Listed):
            cmd = self.commands[name] = load_command(name)  # type: ignore[index]
        return name, cmd, rest


app = typer.Typer(
    name="sidewalk",
    help="Sidewalk: the CMU Terregator/Navlab navigation stack on a Zenoh CODGER blackboard.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    cls=_LazyGroup,
)


@app.callback()
def _top() -> None:
    """Take no options of its own (a callback keeps the app a group while its commands are not yet loaded)."""


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
