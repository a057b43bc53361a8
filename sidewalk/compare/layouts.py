"""Generated layouts in the comparison (`sidewalk compare --generated suburb:20`): written from their seeds, judged per layout.

`KIND:N` asks for layouts of seeds 0..N-1 of a `sidewalk worldgen` kind, written into the
comparison's `layouts/KIND/` (the same seed writes the same files, so the same command runs the
same layouts). Each layout is one mission on its own world (and, with `--with-actors`, once more
with its actors file). The verdict per layout and architecture is the truth's; the totals give the
successes, the goal error's median and 90th percentile over the layouts, and the collisions.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Optional, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

from sidewalk.compare.errors import CompareError
from wire.summary import percentile

__all__ = ["Layout", "LayoutRow", "LayoutTotal", "parse_generated", "write_layouts", "layout_rows", "layout_totals"]


class Layout(BaseModel):
    """One generated layout: its kind and seed, and the files the runs take."""

    model_config = ConfigDict(frozen=True)

    kind: str
    seed: int
    mission: str  # the mission file
    world: str  # the world file (its map beside it)
    actors: str  # the actors file


class LayoutRow(BaseModel):
    """One layout under one architecture, with or without its actors: the truth's verdict, goal error [m], collisions, why it failed."""

    model_config = ConfigDict(frozen=True)

    kind: str
    layout: str
    seed: int  # the run's seed
    architecture: str
    actors: bool
    success: bool
    goal_error_m: Optional[float] = None
    collisions: int = 0
    reason: str = ""


class LayoutTotal(BaseModel):
    """The layouts of one kind under one architecture, with or without actors: successes, goal error median and p90 [m], collisions."""

    model_config = ConfigDict(frozen=True)

    kind: str
    architecture: str
    actors: bool
    layouts: int
    successes: int
    goal_error_median_m: Optional[float] = None
    goal_error_p90_m: Optional[float] = None
    collisions: int = 0


def parse_generated(text: str) -> list[tuple[str, int]]:
    """Return (kind, N) of `KIND:N[,KIND:N]`; raise CompareError naming what is wrong."""
    from vehicle_sim.generated import GENERATORS

    out = []
    for part in (t.strip() for t in text.split(",")):
        m = re.fullmatch(r"([a-z][a-z-]*):(\d+)", part)
        if m is None:
            raise CompareError(f"--generated {part!r}: expected KIND:N, e.g. suburb:20")
        kind, n = m.group(1), int(m.group(2))
        if kind not in GENERATORS:
            raise CompareError(f"--generated {part!r}: unknown kind {kind!r}; known: {', '.join(sorted(GENERATORS))}")
        if not 1 <= n <= 1000:
            raise CompareError(f"--generated {part!r}: N must be 1..1000")
        out.append((kind, n))
    return out


def write_layouts(specs: Sequence[tuple[str, int]], out: Path) -> list[Layout]:
    """Write the layouts of seeds 0..N-1 of each kind into `out/layouts/KIND/`, check their missions; return them."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from vehicle_sim.errors import SimError
    from vehicle_sim.generated import GENERATORS

    layouts = []
    for kind, n in specs:
        d = out / "layouts" / kind
        for seed in range(n):
            try:
                paths = GENERATORS[kind](seed, d, None)
            except (SimError, OSError) as exc:
                raise CompareError(f"--generated {kind}:{n}: seed {seed}: {exc}") from None
            by = {p.name.split(".", 1)[1]: p for p in paths}
            if not {"world.geojson", "yaml", "actors.yaml"} <= set(by):
                raise CompareError(f"--generated {kind}: the kind writes no delivery mission with actors (wrote {sorted(by)})")
            try:
                load_mission(by["yaml"])
            except MissionFileError as exc:
                raise CompareError(f"--generated {kind}:{n}: seed {seed}: {exc}") from None
            layouts.append(Layout(kind=kind, seed=seed, mission=str(by["yaml"]), world=str(by["world.geojson"]),
                                  actors=str(by["actors.yaml"])))
    return layouts


def layout_rows(layouts: Sequence[Layout], entries: Sequence) -> list[LayoutRow]:
    """Return a row per run of a layout (`entries`: RunEntry of the baseline and actors grids; a run without a report failed)."""
    by_mission = {lay.mission: lay for lay in layouts}
    rows = []
    for e in entries:
        lay = by_mission.get(e.mission)
        if lay is None or e.fault is not None or e.max_speed is not None:
            continue
        rep = e.report or {}
        m = e.measures
        rows.append(LayoutRow(kind=lay.kind, layout=Path(lay.mission).stem, seed=e.seed, architecture=e.architecture,
                              actors=e.actors is not None, success=bool(m is not None and m.success == 1.0),
                              goal_error_m=None if m is None else m.goal_error_m,
                              collisions=0 if m is None else int(m.collisions),
                              reason=e.error if m is None else ("" if m.success == 1.0 else str(rep.get("reason", "")))))
    return rows


def layout_totals(rows: Sequence[LayoutRow]) -> list[LayoutTotal]:
    """Return the totals per kind × architecture × with/without actors, in first-seen order."""
    keys = list(dict.fromkeys((r.kind, r.architecture, r.actors) for r in rows))
    out = []
    for kind, arch, actors in keys:
        mine = [r for r in rows if (r.kind, r.architecture, r.actors) == (kind, arch, actors)]
        err = np.array([r.goal_error_m for r in mine if r.goal_error_m is not None and math.isfinite(r.goal_error_m)], float)
        out.append(LayoutTotal(kind=kind, architecture=arch, actors=actors, layouts=len(mine), successes=sum(r.success for r in mine),
                               goal_error_median_m=round(float(np.median(err)), 3) if err.size else None,
                               goal_error_p90_m=percentile(err, 90, digits=3),
                               collisions=sum(r.collisions for r in mine)))
    return out
