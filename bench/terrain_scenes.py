"""Fixed synthetic terrain scenes for the cross-country planner's benchmark and tests, generated from a seed.

A scene is an elevation grid (heights [m], all known, a little range noise) with a start and a goal
50 m apart across it: `hills` (smooth rolling ground), `rocks` (a field of 70 boulders on gentle
ground, none within `CLEAR` of the start, the goal or a ditch's crossing), `ditch` (a steep-banked
ditch across the whole map, filled for 8 m at one place) and `mixed` (all three, with 35 boulders).
Frame `world`, the grid's origin at (0, 0). Nothing here is robot code: it stands in for the
elevation maps the vehicle would build.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modules.terrain.elevation_grid import ElevationGrid

__all__ = ["TerrainScene", "scene", "SCENE_KINDS", "CLEAR"]

SCENE_KINDS = ("hills", "rocks", "ditch", "mixed")
#: No boulder within this distance [m] of the start, the goal or the ditch's crossing: the Navlab, driving forward
#: on arcs of 7 m radius at the tightest, must be able to turn away from what lies ahead of it.
CLEAR = 8.0


@dataclass(frozen=True)
class TerrainScene:
    """A grid and the plan asked on it: start and goal (x [m], y [m], θ [rad]) in `world`."""

    kind: str
    seed: int
    grid: ElevationGrid
    start: tuple[float, float, float]
    goal: tuple[float, float, float]


def scene(kind: str, seed: int, cells: int = 387, resolution: float = 0.2, noise: float = 0.01) -> TerrainScene:
    """Return scene `kind` from `seed` on a `cells` × `cells` grid of `resolution` [m] (default: 149,769 cells, 77.4 m)."""
    if kind not in SCENE_KINDS:
        raise ValueError(f"unknown scene {kind!r}; expected one of {', '.join(SCENE_KINDS)}")
    rng = np.random.default_rng(seed)
    side = cells * resolution
    y, x = (np.mgrid[0:cells, 0:cells] + 0.5) * resolution
    mid = side / 2.0
    start, goal = (mid - 25.0, mid, 0.0), (mid + 25.0, mid, 0.0)
    z = np.zeros((cells, cells))
    clear = [start[:2], goal[:2]]  # where no boulder may lie within CLEAR
    if kind in ("hills", "mixed"):
        for _ in range(12):
            cx, cy = rng.uniform(0.0, side, 2)
            height, sigma = rng.uniform(-1.5, 2.0), rng.uniform(8.0, 16.0)
            z += height * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2.0 * sigma ** 2))
    else:
        z += 0.03 * (x - mid) + 0.02 * (y - mid)  # gentle tilt
    if kind in ("ditch", "mixed"):
        # A ditch 3 m wide and 1 m deep with 45° banks, across the line from start to goal, filled for 8 m at one place.
        x0, lean = mid + rng.uniform(-6.0, 6.0), rng.uniform(-0.2, 0.2)
        across = np.abs(x - (x0 + lean * (y - mid)))
        depth = np.clip(2.5 - across, 0.0, 1.0)
        crossing = mid + rng.choice([-1.0, 1.0]) * rng.uniform(3.0, 8.0)
        depth[np.abs(y - crossing) < 4.0] = 0.0
        z -= depth
        clear.append((x0 + lean * (crossing - mid), crossing))
    if kind in ("rocks", "mixed"):
        placed = 0
        while placed < (70 if kind == "rocks" else 35):
            cx, cy = rng.uniform(0.0, side, 2)
            if min(np.hypot(cx - px, cy - py) for px, py in clear) < CLEAR:
                continue
            radius, height = rng.uniform(0.3, 1.2), rng.uniform(0.3, 1.0)
            r = np.hypot(x - cx, y - cy)
            z += np.where(r < radius, height * (1.0 - 0.3 * (r / radius) ** 2), 0.0)
            placed += 1
    z += noise * rng.standard_normal(z.shape)
    z32 = z.astype(np.float32)
    grid = ElevationGrid(0.0, 0.0, resolution, z32, np.full_like(z32, noise))
    return TerrainScene(kind, seed, grid, start, goal)
