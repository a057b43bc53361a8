"""The simulator's world: a world file (schema in `wire.mapfile`) with vectorised ground queries.

Ground queries (`World.elevation`, `World.label_at`, `World.object_index_at`) are vectorised over
(N, 2) arrays and answered from a raster of the object footprints (resolution `raster_res` [m],
default 0.1 m), painted in `KIND_PRIORITY` order (later features win ties), with elevation computed
analytically from the shape of the object found there, plus, in a world with terrain (its optional
`terrain` raster, `wire.terrainfile`), the terrain's height. The schema names are re-exported here.
"""

from __future__ import annotations

import functools
import math
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

if TYPE_CHECKING:
    from vehicle_sim.actors import ActorSet

from wire.mapfile import (
    COLOUR_TYPES, EDGE_END_TOLERANCE, EDGE_MODES, KIND_PRIORITY, KINDS, MARKING_COLOURS, NODE_KINDS, OBJECT_KINDS, ROLES,
    SHAPES_BY_KIND, WORLDS_DIR, Appearance, ColourStats, ColourType, FlatShape, MapColour, MapFile, Marking, PathEdge, PathNode, PostShape,
    PrismShape, Problem, Shape, SlopeShape, StairsShape, StartPose, Sun, TreeShape, Weather, WorldFileError, WorldObject,
    load_map_file, parse_map_file, world_path,
)

__all__ = [
    "KINDS", "OBJECT_KINDS", "KIND_PRIORITY", "ROLES", "EDGE_MODES", "NODE_KINDS", "SHAPES_BY_KIND",
    "EDGE_END_TOLERANCE", "WorldFileError", "Problem", "COLOUR_TYPES", "ColourType", "MapColour", "ColourStats",
    "Appearance", "Weather", "MARKING_COLOURS", "Marking", "FlatShape", "SlopeShape", "StairsShape",
    "PrismShape", "TreeShape", "PostShape", "Shape", "Sun", "StartPose", "WorldObject", "PathNode", "PathEdge",
    "World", "load_world", "parse_world", "world_path", "WORLDS_DIR",
]


class World(MapFile):
    """A validated world (or map) with vectorised ground queries for the simulator."""

    def __init__(self, *, raster_res: float = 0.1, **fields: Any) -> None:
        """Take `MapFile`'s fields as they are, and `raster_res` [m], the cell of the ground raster."""
        super().__init__(**fields)
        self.actor_set()  # a bad `actors` entry fails the load, naming the file and the entry
        self.raster_res = float(raster_res)
        self._raster: np.ndarray | None = None
        self._origin = np.zeros(2)

    def actor_set(self) -> "ActorSet":
        """Return the world file's actors (objects not on the map, `vehicle_sim.actors`); raise WorldFileError for a bad entry."""
        from vehicle_sim.actors import ActorError, actors_from_doc

        try:
            return actors_from_doc({"actors": list(self.actors)}, self.source)
        except ActorError as exc:
            raise WorldFileError(self.source, [Problem(field="actors", message=str(exc).removeprefix(f"{self.source}: "))]) from None

    # ---- ground queries ----------------------------------------------------------------

    def _ensure_raster(self) -> np.ndarray:
        if self._raster is not None:
            return self._raster
        import cv2

        xmin, ymin, xmax, ymax = self.bounds(margin=1.0)
        res = self.raster_res
        w = int(math.ceil((xmax - xmin) / res)) + 1
        h = int(math.ceil((ymax - ymin) / res)) + 1
        raster = np.zeros((h, w), dtype=np.int16)  # object index + 1; 0 = nothing
        order = sorted(range(len(self.objects)), key=lambda i: (KIND_PRIORITY[self.objects[i].kind], i))
        shift = 4
        scale = (1 << shift) / res
        for i in order:
            o = self.objects[i]
            if o.is_point:
                cx = int(round((o.center[0] - xmin) * scale - 0.5 * (1 << shift)))  # type: ignore[index]
                cy = int(round((o.center[1] - ymin) * scale - 0.5 * (1 << shift)))  # type: ignore[index]
                r = max(int(round(o.radius * scale)), 1)  # type: ignore[operator]
                cv2.circle(raster, (cx, cy), r, int(i + 1), thickness=-1, lineType=cv2.LINE_8, shift=shift)
            else:
                pts = np.round((o.vertices - [xmin, ymin]) * scale - 0.5 * (1 << shift)).astype(np.int32)
                cv2.fillPoly(raster, [pts.reshape(-1, 1, 2)], int(i + 1), lineType=cv2.LINE_8, shift=shift)
        self._raster = raster
        self._origin = np.array([xmin, ymin])
        return raster

    def object_index_at(self, xy: np.ndarray) -> np.ndarray:
        """Return the index into `objects` of the top object at ground points `xy` (N, 2) [m] → (N,) int, -1 = none."""
        raster = self._ensure_raster()
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        ij = np.floor((xy - self._origin) / self.raster_res).astype(np.int64)
        h, w = raster.shape
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < w) & (ij[:, 1] >= 0) & (ij[:, 1] < h)
        out = np.full(len(xy), -1, dtype=np.int64)
        out[inside] = raster[ij[inside, 1], ij[inside, 0]].astype(np.int64) - 1
        return out

    @cached_property
    def _kind_lut(self) -> np.ndarray:
        lut = np.zeros(len(self.objects) + 1, dtype=np.int16)
        for i, o in enumerate(self.objects):
            lut[i + 1] = o.kind_index
        return lut

    @cached_property
    def _role_lut(self) -> np.ndarray:
        lut = np.full(len(self.objects) + 1, ROLES.index("none"), dtype=np.int8)
        for i, o in enumerate(self.objects):
            lut[i + 1] = ROLES.index(o.role)
        return lut

    def label_at(self, xy: np.ndarray) -> np.ndarray:
        """Return the class index into `KINDS` of the top object at ground points `xy` (N, 2) [m] → (N,) int."""
        return self._kind_lut[self.object_index_at(xy) + 1].astype(np.int64)

    def role_at(self, xy: np.ndarray) -> np.ndarray:
        """Return the role index into `ROLES` at ground points `xy` (N, 2) [m] → (N,) int ("none" where empty)."""
        return self._role_lut[self.object_index_at(xy) + 1].astype(np.int64)

    def elevation(self, xy: np.ndarray) -> np.ndarray:
        """Return the ground height z [m] at points `xy` (N, 2) [m], world frame → (N,) float64.

        The ground of flat/slope/stairs objects is their surface; under standing objects (buildings,
        trees, posts) it is their base `z0`; outside every object it is 0; in a world with terrain,
        each of these lies on the terrain (its height added).
        """
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        idx = self.object_index_at(xy)
        z = self.terrain_raster.height(xy) if self.terrain_raster is not None else np.zeros(len(xy))
        z += self._level_lut[idx + 1]  # flat covers and standing objects: one height each
        for i in self._non_zero_ground:
            m = idx == i
            if m.any():
                z[m] += self.objects[i].ground_z(xy[m])
        return z

    def elevation_at(self, x: float, y: float) -> float:
        """Return the ground height z [m] at one point (x, y) [m], world frame (scalar fast path of `elevation`)."""
        raster = self._ensure_raster()
        h, w = raster.shape
        i = int(math.floor((x - self._origin[0]) / self.raster_res))
        j = int(math.floor((y - self._origin[1]) / self.raster_res))
        base = self.terrain_raster.height_at(x, y) if self.terrain_raster is not None else 0.0
        if not (0 <= i < w and 0 <= j < h):
            return base
        k = int(raster[j, i])
        return base + self.objects[k - 1].ground_z_at(x, y) if k > 0 else base

    @cached_property
    def _level_lut(self) -> np.ndarray:
        """Return the ground height [m] of each object of one level (flat covers, standing objects) by index + 1, else 0."""
        lut = np.zeros(len(self.objects) + 1)
        for i, o in enumerate(self.objects):
            s = o.shape
            if isinstance(s, FlatShape):
                lut[i + 1] = s.z
            elif isinstance(s, (PrismShape, TreeShape, PostShape)):
                lut[i + 1] = s.z0
        return lut

    @cached_property
    def _non_zero_ground(self) -> tuple[int, ...]:
        """Return the indices of the objects whose ground is not level (slopes, stairs)."""
        return tuple(i for i, o in enumerate(self.objects) if isinstance(o.shape, (SlopeShape, StairsShape)))


def load_world(path: str | Path, *, kind: Literal["world", "map"] = "world", raster_res: float = 0.1) -> World:
    """Load and validate a world or map file (a name like "campus" or a path); raise `WorldFileError`."""
    return load_map_file(path, kind=kind, factory=functools.partial(World, raster_res=raster_res))


def parse_world(text: str | dict, *, source: str = "<string>", raster_res: float = 0.1) -> World:
    """Parse and validate GeoJSON text (or an already-decoded dict); raise `WorldFileError`."""
    return parse_map_file(text, source=source, factory=functools.partial(World, raster_res=raster_res))
