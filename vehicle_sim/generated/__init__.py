"""Generated worlds: a generator per kind, each from a seed, every output valid by the world/map schema and checked.

`GENERATORS` maps a kind (the `sidewalk worldgen KIND` argument) to a function `(seed, out_dir, name) -> written paths`
(`name` None: the kind's own name for the seed);
a new kind (suburb, marked road, campus) adds its module here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

__all__ = ["GENERATORS"]


def _cross_country(seed: int, out: Path, name: str | None = None) -> list[Path]:
    from vehicle_sim.generated.cross_country import generate, write

    return write(generate(seed, name=name), out)


def _suburb(seed: int, out: Path, name: str | None = None) -> list[Path]:
    from vehicle_sim.generated.suburb import generate, write

    return write(generate(seed, name=name), out)


def _marked_road(seed: int, out: Path, name: str | None = None) -> list[Path]:
    from vehicle_sim.generated.marked_road import generate, write

    return write(generate(seed, name=name), out)


def _campus(seed: int, out: Path, name: str | None = None) -> list[Path]:
    from vehicle_sim.generated.campus import generate, write

    return write(generate(seed, name=name), out)


#: kind → (seed, output directory, name or None) → the files written
GENERATORS: dict[str, Callable[[int, Path, str | None], list[Path]]] = {
    "cross-country": _cross_country,
    "suburb": _suburb,
    "marked-road": _marked_road,
    "campus": _campus,
}
