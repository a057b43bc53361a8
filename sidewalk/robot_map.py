"""The map the robot is told for a world: never the world itself.

A world named by its name ("campus") has its map in `worlds/<name>.map.geojson`; a world given as a
file (`some/dir/NAME.world.geojson`) has its map beside it, `some/dir/NAME.map.geojson`. Without that
file the run is refused: handing the robot the world (truth) instead would make every map error 0.
"""

from __future__ import annotations

from pathlib import Path

from sidewalk.errors import SidewalkError
from wire.mapfile import world_path

__all__ = ["MissingMapError", "map_beside"]


class MissingMapError(SidewalkError, FileNotFoundError):
    """A world has no map file beside it (the message names the file expected)."""


def _is_file(world: str | Path) -> bool:
    p = Path(world)
    return p.suffix in (".geojson", ".json") or p.exists()


def map_beside(world: str | Path) -> Path:
    """Return the map file of `world` (a name or a world file); raise MissingMapError naming the file expected."""
    if not _is_file(world):
        try:
            return world_path(world, kind="map")
        except FileNotFoundError as exc:
            raise MissingMapError(str(exc)) from None
    p = Path(world)
    sibling = p.with_name(f"{p.name.split('.')[0]}.map.geojson")
    if not sibling.is_file():
        raise MissingMapError(f"{p}: no map beside this world ({sibling} does not exist); the robot is never given the "
                              "world: write that map, or name one with --map FILE")
    return sibling
