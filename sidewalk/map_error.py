"""How wrong a map is, measured against the world file it describes (evaluation: reads truth)."""

from __future__ import annotations

from typing import Optional

import numpy as np
from pydantic import BaseModel, ConfigDict

from wire.mapfile import MapFile, WorldObject

__all__ = ["MapErrorSummary", "measure_map_error"]


class MapErrorSummary(BaseModel):
    """The realised error of a map: vertex displacement of path objects and landmarks [m], objects left out.

    `requested_m` is the `--map-error` asked for (None: the shipped map).
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    path_mean_m: float
    path_max_m: float
    landmark_mean_m: float
    landmark_max_m: float
    missing: int
    requested_m: Optional[float] = None


def _corners(o: WorldObject) -> np.ndarray:
    """Return the vertices a map file gives an object: its polygon (M,2), or its centre (1,2) [m]."""
    return np.asarray(o.polygon if o.polygon is not None else (o.center,), dtype=float)


def _displacements(true: WorldObject, mapped: WorldObject) -> np.ndarray:
    """Return each map vertex's distance from its true vertex [m] (by index; nearest true vertex if the counts differ)."""
    a, b = _corners(true), _corners(mapped)
    if len(a) == len(b):
        return np.hypot(*(b - a).T)
    return np.min(np.hypot(b[:, None, 0] - a[None, :, 0], b[:, None, 1] - a[None, :, 1]), axis=1)


def measure_map_error(world: MapFile, map_: MapFile, *, requested_m: float | None = None) -> MapErrorSummary:
    """Match the map's objects to the world's by id; summarise the vertex displacements and count the missing ones."""
    by_role: dict[str, list[np.ndarray]] = {"path": [], "landmark": []}
    missing = 0
    for o in world.objects:
        if not map_.has_object(o.id):
            missing += 1
            continue
        if o.role in by_role:
            by_role[o.role].append(_displacements(o, map_.object(o.id)))

    def mean_max(parts: list[np.ndarray]) -> tuple[float, float]:
        if not parts:
            return 0.0, 0.0
        d = np.concatenate(parts)
        return round(float(d.mean()), 4), round(float(d.max()), 4)

    pm, px = mean_max(by_role["path"])
    lm, lx = mean_max(by_role["landmark"])
    return MapErrorSummary(path_mean_m=pm, path_max_m=px, landmark_mean_m=lm, landmark_max_m=lx, missing=missing,
                           requested_m=requested_m)
