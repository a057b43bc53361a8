"""World and map files: the GeoJSON schema shared by the simulator and the MAP NAVIGATOR, and its loader.

A world (the truth) and a map (what the robot is told) share one schema: a GeoJSON
FeatureCollection in the `world` frame (x east [m], y north [m], z up [m]). See worlds/README.md.

Two feature families:

* objects (`kind` in `OBJECT_KINDS`): a Polygon area or a Point with a footprint `radius` [m],
  with role, cost, a colour (what a map says: a colour type such as GRAY or GREEN and a nominal
  colour, Sidewalk 1986 §3) and a 3-D `shape`;
* the path graph: `node` features (Point) and `edge` features (LineString from node to node).

A world file also says how things look, which no map says: each object's `appearance` (its own
colour statistics, laser reflectance, a tree's crown) and the collection's `weather` (wet patches
and leaves that come and go over a run). A map derived from a world drops both (`MapFile.as_map`).

The map belongs to no simulator: the MAP NAVIGATOR reads it through this module, the simulator
adds its ground queries in `vehicle_sim.worldfile.World`.
"""

from __future__ import annotations

import json
import math
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, Callable, Iterable, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator
from wire.errors import WireError
from wire.terrainfile import TerrainFileError, TerrainRaster, TerrainRef, load_terrain

__all__ = [
    "KINDS",
    "OBJECT_KINDS",
    "KIND_PRIORITY",
    "ROLES",
    "EDGE_MODES",
    "NODE_KINDS",
    "EdgeMode",
    "SHAPES_BY_KIND",
    "WorldFileError",
    "Problem",
    "COLOUR_TYPES",
    "ColourType",
    "MapColour",
    "ColourStats",
    "Appearance",
    "Weather",
    "MARKING_COLOURS",
    "Marking",
    "FlatShape",
    "SlopeShape",
    "StairsShape",
    "PrismShape",
    "TreeShape",
    "PostShape",
    "Shape",
    "Sun",
    "StartPose",
    "WorldObject",
    "PathNode",
    "PathEdge",
    "MapFile",
    "load_map_file",
    "parse_map_file",
    "world_path",
    "WORLDS_DIR",
]

#: Directory holding the shipped world and map files.
WORLDS_DIR = Path(__file__).resolve().parent.parent / "worlds"

#: Class names for per-pixel labels; `label_at` returns indices into this tuple.
#: "none" = no object there; "sky" is for sensors (rays that hit nothing), never returned by `label_at`.
KINDS: tuple[str, ...] = (
    "none",
    "grass",
    "road",
    "driveway",
    "sidewalk",
    "intersection",
    "slope",
    "stairs",
    "building",
    "tree",
    "mailbox",
    "lamp_post",
    "bench",
    "hedge",
    "sign",
    "hydrant",
    "wall",
    "rock",
    "sky",
)

#: Kinds an object feature may have.
OBJECT_KINDS: tuple[str, ...] = tuple(k for k in KINDS if k not in ("none", "sky"))

#: Painting priority for ground queries: higher paints over lower; ties: later feature wins.
KIND_PRIORITY: dict[str, int] = {
    "grass": 0,
    "driveway": 1,
    "road": 2,
    "sidewalk": 3,
    "intersection": 4,
    "slope": 5,
    "stairs": 5,
    "hedge": 6,
    "wall": 6,
    "rock": 6,
    "building": 7,
    "tree": 8,
    "mailbox": 8,
    "lamp_post": 8,
    "bench": 8,
    "sign": 8,
    "hydrant": 8,
}

ROLES: tuple[str, ...] = ("path", "landmark", "obstacle", "none")
EDGE_MODES: tuple[str, ...] = (
    "follow-road",
    "go-through-slope",
    "climb-stairs",
    "turn-at-intersection",
    "go-through-intersection",
)
NODE_KINDS: tuple[str, ...] = ("intersection", "place")
#: The navigation mode of a path-graph edge (one of `EDGE_MODES`).
EdgeMode = Literal["follow-road", "go-through-slope", "climb-stairs", "turn-at-intersection", "go-through-intersection"]

#: Which shape types each kind may carry (ground covers are flat/slope; stairs are stairs; …).
SHAPES_BY_KIND: dict[str, tuple[str, ...]] = {
    "grass": ("flat", "slope"),
    "road": ("flat", "slope"),
    "driveway": ("flat", "slope"),
    "sidewalk": ("flat", "slope"),
    "intersection": ("flat", "slope"),
    "slope": ("slope",),
    "stairs": ("stairs",),
    "building": ("prism",),
    "hedge": ("prism",),
    "wall": ("prism",),
    "rock": ("prism", "post", "flat"),  # flat: a rock of a terrain world, its shape in the terrain raster
    "tree": ("tree",),
    "mailbox": ("post", "prism"),
    "lamp_post": ("post",),
    "bench": ("prism", "post"),
    "sign": ("post",),
    "hydrant": ("post",),
}

#: Largest allowed gap between an edge's end and its node [m].
EDGE_END_TOLERANCE = 0.5


# --------------------------------------------------------------------------------------------
# errors


class Problem(BaseModel):
    """One thing wrong in a world file: where (feature index and id, field) and what."""

    model_config = ConfigDict(frozen=True)

    index: int | None = None
    feature_id: str | None = None
    field: str | None = None
    message: str

    def __str__(self) -> str:
        where = []
        if self.index is not None:
            where.append(f"feature #{self.index}")
        if self.feature_id is not None:
            where.append(f"id {self.feature_id!r}")
        head = " ".join(where) if where else "collection"
        fld = f" {self.field}:" if self.field else ":"
        return f"{head}{fld} {self.message}"


class WorldFileError(WireError, ValueError):
    """A world or map file that cannot be used; names the file, each bad feature and what is wrong."""

    def __init__(self, source: str, problems: Iterable[Problem]):
        self.source = source
        self.problems: tuple[Problem, ...] = tuple(problems)
        lines = [f"{source}: {len(self.problems)} problem(s)"]
        lines += [f"  {source}: {p}" for p in self.problems]
        super().__init__("\n".join(lines))


# --------------------------------------------------------------------------------------------
# property models

_FROZEN = ConfigDict(frozen=True, extra="forbid")


#: Colour types a map names (Sidewalk 1986 §3.3.4: "the types of color are GRAY and GREEN").
COLOUR_TYPES: tuple[str, ...] = ("GRAY", "GREEN", "BROWN", "RED", "BLUE", "YELLOW", "WHITE", "BLACK")
#: One of `COLOUR_TYPES`.
ColourType = Literal["GRAY", "GREEN", "BROWN", "RED", "BLUE", "YELLOW", "WHITE", "BLACK"]


def _rgb_range(v: tuple[float, float, float], hi: float = 255.0) -> tuple[float, float, float]:
    if not all(0.0 <= c <= hi and math.isfinite(c) for c in v):
        raise ValueError(f"each channel must be within 0..{hi:g}, got {list(v)}")
    return v


class MapColour(BaseModel):
    """What a map says of an object's colour: its colour type and a nominal sRGB colour in daylight [0–255].

    The nominal colour is a catalogue value (\"light gray concrete\"), not a measurement: the surface
    itself varies from object to object and over a run, and PERCEPTION adapts to what it sees.
    """

    model_config = _FROZEN

    type: ColourType
    nominal: tuple[float, float, float]

    @field_validator("nominal")
    @classmethod
    def _nominal_range(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        return _rgb_range(v)


class ColourStats(BaseModel):
    """Gaussian colour statistics in sRGB under full sun: mean and standard deviation per channel [0–255]."""

    model_config = _FROZEN

    mean: tuple[float, float, float]
    std: tuple[float, float, float]

    @field_validator("mean")
    @classmethod
    def _mean_range(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        return _rgb_range(v)

    @field_validator("std")
    @classmethod
    def _std_range(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        return _rgb_range(v, 128.0)


class Appearance(ColourStats):
    """How the renderer draws a world object (world files only, never a map): colour statistics under full
    sun [0–255] (this object's own, weathering included), laser reflectance [0–1], a tree's crown colour."""

    reflectance: float = Field(default=0.5, ge=0.0, le=1.0)
    crown: ColourStats | None = None


class Weather(BaseModel):
    """How ground covers change over a run (world files only): wet patches that dry and return, fallen leaves.

    Each cover's share of the ground (`wet_cover`, `leaf_cover`, 0–1) swings by ±`swing` (relative)
    around its mean with period `period_s` [s] sim time; wet ground keeps `wet_brightness` (0–1] of its
    dry brightness; leaves have the colour statistics `leaves` [0–255].
    """

    model_config = _FROZEN

    wet_cover: float = Field(default=0.0, ge=0.0, le=1.0)
    wet_brightness: float = Field(default=0.6, gt=0.0, le=1.0)
    leaf_cover: float = Field(default=0.0, ge=0.0, le=1.0)
    leaves: ColourStats = ColourStats(mean=(150.0, 100.0, 50.0), std=(22.0, 18.0, 14.0))
    swing: float = Field(default=0.6, ge=0.0, le=1.0)
    period_s: float = Field(default=300.0, gt=0.0)


#: Paint colours of road markings (Navlab 1990 §2.2.2: yellow centre lines, white edge stripes).
MARKING_COLOURS: tuple[str, ...] = ("yellow", "white")


class Marking(BaseModel):
    """A painted stripe on a road (world files only): a polyline [m] in `world`, paint colour, width [m], dashes.

    `dash` is (painted, gap) [m] along the line for a broken stripe, None for a solid one. The stripe is
    drawn where it lies on its road; a map never states markings (a derived map drops them).
    """

    model_config = _FROZEN

    colour: Literal["yellow", "white"]
    line: tuple[tuple[float, float], ...] = Field(min_length=2)
    width: float = Field(gt=0.02, le=1.0)
    dash: tuple[float, float] | None = None

    @field_validator("line")
    @classmethod
    def _line_finite(cls, v: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
        if not all(math.isfinite(c) for p in v for c in p):
            raise ValueError("every position must be finite")
        if any(p == q for p, q in zip(v, v[1:])):
            raise ValueError("consecutive positions must differ")
        return v

    @field_validator("dash")
    @classmethod
    def _dash_positive(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not (v[0] > 0.0 and v[1] > 0.0 and math.isfinite(v[0] + v[1])):
            raise ValueError(f"dash is (painted, gap) [m], both > 0, got {list(v)}")
        return v


def _finite(v: float, name: str) -> float:
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite")
    return v


class FlatShape(BaseModel):
    """A horizontal surface at height `z` [m]."""

    model_config = _FROZEN
    type: Literal["flat"] = "flat"
    z: float = 0.0


class SlopeShape(BaseModel):
    """A plane rising `rise` [m] across the polygon along math angle `axis_deg` [deg] (CCW from +x) from `z0` [m]."""

    model_config = _FROZEN
    type: Literal["slope"] = "slope"
    z0: float = 0.0
    rise: float
    axis_deg: float


class StairsShape(BaseModel):
    """Steps rising `rise` [m] across the polygon along `axis_deg` [deg] from `z0` [m], `step_rise` [m] each."""

    model_config = _FROZEN
    type: Literal["stairs"] = "stairs"
    z0: float = 0.0
    rise: float = Field(gt=0)
    axis_deg: float
    step_rise: float = Field(gt=0)

    @property
    def n_steps(self) -> int:
        """Return the number of steps (risers)."""
        return max(1, int(round(self.rise / self.step_rise)))


class PrismShape(BaseModel):
    """A vertical extrusion of the footprint, `height` [m] tall, standing at `z0` [m]."""

    model_config = _FROZEN
    type: Literal["prism"] = "prism"
    height: float = Field(gt=0)
    z0: float = 0.0


class TreeShape(BaseModel):
    """A trunk cylinder and a crown sphere-ish ellipsoid: radii [m], total height [m], crown base [m]."""

    model_config = _FROZEN
    type: Literal["tree"] = "tree"
    trunk_radius: float = Field(gt=0)
    crown_radius: float = Field(gt=0)
    height: float = Field(gt=0)
    crown_base: float = Field(ge=0)
    z0: float = 0.0


class PostShape(BaseModel):
    """A vertical cylinder of the footprint radius, `height` [m] tall, standing at `z0` [m]."""

    model_config = _FROZEN
    type: Literal["post"] = "post"
    height: float = Field(gt=0)
    z0: float = 0.0


Shape = Annotated[
    Union[FlatShape, SlopeShape, StairsShape, PrismShape, TreeShape, PostShape],
    Field(discriminator="type"),
]


class _ObjectProps(BaseModel):
    model_config = _FROZEN
    id: str = Field(min_length=1)
    kind: str
    role: Literal["path", "landmark", "obstacle", "none"]
    cost: float | None = None
    colour: MapColour
    appearance: Appearance | None = None
    shape: Shape
    name: str | None = None
    radius: float | None = None
    markings: tuple[Marking, ...] = ()

    @field_validator("colour", mode="before")
    @classmethod
    def _colour_is_a_type(cls, v: Any) -> Any:
        if isinstance(v, dict) and ("mean" in v or "std" in v) and "type" not in v:
            raise ValueError('give the colour a map states: {"type": "GRAY", "nominal": [r, g, b]}; '
                             'colour statistics (mean, std) belong in "appearance" (world files only)')
        return v


class _NodeProps(BaseModel):
    model_config = _FROZEN
    id: str = Field(min_length=1)
    kind: Literal["node"]
    node_kind: Literal["intersection", "place"]
    name: str | None = None
    object: str | None = None


class _EdgeProps(BaseModel):
    model_config = _FROZEN
    id: str = Field(min_length=1)
    kind: Literal["edge"]
    from_: str = Field(alias="from", min_length=1)
    to: str = Field(min_length=1)
    mode: EdgeMode
    path_objects: tuple[str, ...] = ()
    width: float = Field(gt=0)
    name: str | None = None


class Sun(BaseModel):
    """The sun direction: compass azimuth [deg] (0 = north, 90 = east) and elevation above the horizon [deg]."""

    model_config = _FROZEN
    azimuth_deg: float = Field(ge=0.0, le=360.0)
    elevation_deg: float = Field(gt=0.0, le=90.0)

    def direction(self) -> np.ndarray:
        """Return the unit vector towards the sun in the world frame (x east, y north, z up), shape (3,)."""
        az = math.radians(self.azimuth_deg)
        el = math.radians(self.elevation_deg)
        return np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])


class StartPose(BaseModel):
    """The vehicle's start pose in the world frame: x, y [m], yaw [deg] CCW from +x; optional graph node."""

    model_config = _FROZEN
    x: float
    y: float
    yaw_deg: float
    node: str | None = None

    @property
    def yaw(self) -> float:
        """Return the start yaw [rad]."""
        return math.radians(self.yaw_deg)


# --------------------------------------------------------------------------------------------
# public feature models


class WorldObject(BaseModel):
    """One object of the world: an area (`polygon`) or a round footprint (`center` + `radius`) [m], world frame.

    `colour` is what a map says (colour type, nominal colour); `appearance` what the renderer needs
    (world files only; None in a map).
    """

    model_config = ConfigDict(frozen=True)

    id: str
    kind: str
    role: Literal["path", "landmark", "obstacle", "none"]
    cost: float = math.inf
    colour: MapColour
    appearance: Appearance | None = None
    shape: Union[FlatShape, SlopeShape, StairsShape, PrismShape, TreeShape, PostShape]
    name: str | None = None
    polygon: tuple[tuple[float, float], ...] | None = None
    center: tuple[float, float] | None = None
    radius: float | None = None
    markings: tuple[Marking, ...] = ()

    @property
    def is_point(self) -> bool:
        """Return True for round (Point + radius) objects."""
        return self.center is not None

    @property
    def kind_index(self) -> int:
        """Return the label index of this object's kind in `KINDS`."""
        return KINDS.index(self.kind)

    @property
    def traversable(self) -> bool:
        """Return True when the cost is finite."""
        return math.isfinite(self.cost)

    @cached_property
    def vertices(self) -> np.ndarray:
        """Return the footprint outline, (M, 2) float64 [m], world frame, not closed (circles as 32-gons)."""
        if self.polygon is not None:
            return np.asarray(self.polygon, dtype=np.float64)
        assert self.center is not None and self.radius is not None
        a = np.linspace(0.0, 2.0 * math.pi, 32, endpoint=False)
        return np.column_stack([self.center[0] + self.radius * np.cos(a), self.center[1] + self.radius * np.sin(a)])

    @cached_property
    def footprint(self) -> Any:
        """Return the footprint as a shapely geometry (Polygon), world frame [m]."""
        import shapely

        if self.polygon is not None:
            return shapely.Polygon(self.polygon)
        assert self.center is not None and self.radius is not None
        return shapely.Point(self.center).buffer(self.radius, quad_segs=8)

    def axis_extent(self) -> tuple[float, float]:
        """Return (min, max) of the footprint projected on the shape's axis [m] (slopes and stairs)."""
        shape = self.shape
        assert isinstance(shape, (SlopeShape, StairsShape))
        a = math.radians(shape.axis_deg)
        proj = self.vertices @ np.array([math.cos(a), math.sin(a)])
        return float(proj.min()), float(proj.max())

    def ground_z(self, xy: np.ndarray) -> np.ndarray:
        """Return the ground surface height of this object at points `xy` (N, 2) [m] → (N,) [m].

        Flat, slope and stairs shapes give their surface; standing objects give their base `z0`.
        """
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        shape = self.shape
        if isinstance(shape, FlatShape):
            return np.full(len(xy), shape.z)
        if isinstance(shape, (SlopeShape, StairsShape)):
            lo, hi = self.axis_extent()
            a = math.radians(shape.axis_deg)
            t = (xy @ np.array([math.cos(a), math.sin(a)]) - lo) / max(hi - lo, 1e-9)
            t = np.clip(t, 0.0, 1.0)
            if isinstance(shape, SlopeShape):
                return shape.z0 + shape.rise * t
            n = shape.n_steps
            k = np.minimum(np.floor(t * n), n - 1) + 1.0
            return shape.z0 + shape.rise * k / n
        return np.full(len(xy), shape.z0)

    def ground_z_at(self, x: float, y: float) -> float:
        """Return the ground surface height of this object at one point (x, y) [m] → [m] (scalar fast path)."""
        shape = self.shape
        if isinstance(shape, FlatShape):
            return shape.z
        if isinstance(shape, (SlopeShape, StairsShape)):
            lo, hi = self._axis
            a = math.radians(shape.axis_deg)
            t = ((x * math.cos(a) + y * math.sin(a)) - lo) / max(hi - lo, 1e-9)
            t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
            if isinstance(shape, SlopeShape):
                return shape.z0 + shape.rise * t
            n = shape.n_steps
            return shape.z0 + shape.rise * (min(math.floor(t * n), n - 1) + 1.0) / n
        return shape.z0

    @cached_property
    def _axis(self) -> tuple[float, float]:
        return self.axis_extent()

    def as_mapped(self) -> "WorldObject":
        """Return this object as a map states it: colour type and nominal colour, no appearance, no markings."""
        if self.appearance is None and not self.markings:
            return self
        return self.model_copy(update={"appearance": None, "markings": ()})

    def to_feature(self) -> dict:
        """Return this object as a GeoJSON Feature dict."""
        props: dict[str, Any] = {"id": self.id, "kind": self.kind, "role": self.role}
        if math.isfinite(self.cost):
            props["cost"] = self.cost
        props["colour"] = self.colour.model_dump()
        if self.appearance is not None:
            props["appearance"] = self.appearance.model_dump(exclude_none=True)
        props["shape"] = self.shape.model_dump(exclude_none=True)
        if self.name is not None:
            props["name"] = self.name
        if self.markings:
            props["markings"] = [m.model_dump(exclude_none=True) for m in self.markings]
        if self.polygon is not None:
            ring = [list(p) for p in self.polygon] + [list(self.polygon[0])]
            geom = {"type": "Polygon", "coordinates": [ring]}
        else:
            props["radius"] = self.radius
            geom = {"type": "Point", "coordinates": list(self.center)}  # type: ignore[arg-type]
        return {"type": "Feature", "geometry": geom, "properties": props}


class PathNode(BaseModel):
    """A path-graph node: an intersection or a named place, at (x, y) [m] in the world frame."""

    model_config = ConfigDict(frozen=True)

    id: str
    node_kind: Literal["intersection", "place"]
    x: float
    y: float
    name: str | None = None
    object_id: str | None = None

    @property
    def xy(self) -> np.ndarray:
        """Return the position, shape (2,) [m]."""
        return np.array([self.x, self.y])

    def to_feature(self) -> dict:
        """Return this node as a GeoJSON Feature dict."""
        props: dict[str, Any] = {"id": self.id, "kind": "node", "node_kind": self.node_kind}
        if self.name is not None:
            props["name"] = self.name
        if self.object_id is not None:
            props["object"] = self.object_id
        return {"type": "Feature", "geometry": {"type": "Point", "coordinates": [self.x, self.y]}, "properties": props}


class PathEdge(BaseModel):
    """A path-graph edge from node to node along a polyline [m] (world frame), traversable both ways."""

    model_config = ConfigDict(frozen=True)

    id: str
    from_node: str
    to_node: str
    mode: EdgeMode
    path_objects: tuple[str, ...] = ()
    width: float
    coords: tuple[tuple[float, float], ...]
    name: str | None = None

    @property
    def points(self) -> np.ndarray:
        """Return the polyline, (K, 2) float64 [m]."""
        return np.asarray(self.coords, dtype=np.float64)

    @property
    def length(self) -> float:
        """Return the polyline length [m]."""
        p = self.points
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())

    def other(self, node_id: str) -> str:
        """Return the node at the other end from `node_id`."""
        return self.to_node if node_id == self.from_node else self.from_node

    def to_feature(self) -> dict:
        """Return this edge as a GeoJSON Feature dict."""
        props: dict[str, Any] = {
            "id": self.id,
            "kind": "edge",
            "from": self.from_node,
            "to": self.to_node,
            "mode": self.mode,
            "path_objects": list(self.path_objects),
            "width": self.width,
        }
        if self.name is not None:
            props["name"] = self.name
        return {
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": [list(c) for c in self.coords]},
            "properties": props,
        }


# --------------------------------------------------------------------------------------------
# the world


class MapFile:
    """A validated world or map file: objects, path graph, sun and start, with look-ups.

    Construct through `load_map_file` / `parse_map_file`, or directly (the constructor validates the
    cross references and raises `WorldFileError` with `source` as the file name). The simulator's
    `vehicle_sim.worldfile.World` adds ground queries to it.
    """

    def __init__(
        self,
        *,
        name: str,
        objects: Iterable[WorldObject],
        nodes: Iterable[PathNode] = (),
        edges: Iterable[PathEdge] = (),
        sun: Sun | None = None,
        start: StartPose | None = None,
        source: str = "<memory>",
        weather: Weather | None = None,
        actors: Iterable[dict] = (),
        terrain: TerrainRef | None = None,
        terrain_raster: TerrainRaster | None = None,
    ) -> None:
        self.name = name
        #: the optional `terrain` entry (a raster file beside this one, `wire.terrainfile`) and its raster, loaded
        self.terrain: TerrainRef | None = terrain
        self.terrain_raster: TerrainRaster | None = terrain_raster
        if (terrain is None) != (terrain_raster is None):
            raise WorldFileError(source, [Problem(field="terrain", message="a terrain entry needs its raster, and a raster its entry")])
        #: objects not on the map (the world file's optional `actors` list, truth for the simulator only):
        #: kept as written; `vehicle_sim.worldfile.World` validates them
        self.actors: tuple[dict, ...] = tuple(actors)
        self.objects: tuple[WorldObject, ...] = tuple(objects)
        self.nodes: tuple[PathNode, ...] = tuple(nodes)
        self.edges: tuple[PathEdge, ...] = tuple(edges)
        self.sun: Sun = sun or Sun(azimuth_deg=200.0, elevation_deg=40.0)
        self.start: StartPose | None = start
        self.weather: Weather | None = weather
        self.source = source
        self._obj_by_id = {o.id: o for o in self.objects}
        self._node_by_id = {n.id: n for n in self.nodes}
        self._edge_by_id = {e.id: e for e in self.edges}
        self._obj_index = {o.id: i for i, o in enumerate(self.objects)}
        problems = _cross_check(self.objects, self.nodes, self.edges, self.start)
        if problems:
            raise WorldFileError(source, problems)

    # ---- lookup -------------------------------------------------------------------------

    def object(self, object_id: str) -> WorldObject:
        """Return the object with this id (KeyError if absent)."""
        return self._obj_by_id[object_id]

    def has_object(self, object_id: str) -> bool:
        """Return True when an object with this id exists."""
        return object_id in self._obj_by_id

    def object_index(self, object_id: str) -> int:
        """Return the index of the object with this id in `objects`."""
        return self._obj_index[object_id]

    def node(self, node_id: str) -> PathNode:
        """Return the path node with this id (KeyError if absent)."""
        return self._node_by_id[node_id]

    def edge(self, edge_id: str) -> PathEdge:
        """Return the path edge with this id (KeyError if absent)."""
        return self._edge_by_id[edge_id]

    def place(self, name: str) -> PathNode:
        """Return the node named `name` (KeyError listing the known names if absent)."""
        for n in self.nodes:
            if n.name == name:
                return n
        raise KeyError(f"no place named {name!r} in world {self.name!r}; known: {sorted(self.place_names())}")

    def place_names(self) -> tuple[str, ...]:
        """Return the names of every named node."""
        return tuple(n.name for n in self.nodes if n.name is not None)

    def objects_of_kind(self, *kinds: str) -> tuple[WorldObject, ...]:
        """Return the objects whose kind is one of `kinds`."""
        return tuple(o for o in self.objects if o.kind in kinds)

    def edges_at(self, node_id: str) -> tuple[PathEdge, ...]:
        """Return the edges touching node `node_id`."""
        return tuple(e for e in self.edges if node_id in (e.from_node, e.to_node))

    @property
    def intersections(self) -> tuple[PathNode, ...]:
        """Return the intersection nodes."""
        return tuple(n for n in self.nodes if n.node_kind == "intersection")

    def bounds(self, margin: float = 0.0) -> tuple[float, float, float, float]:
        """Return (xmin, ymin, xmax, ymax) [m] of every object footprint, grown by `margin` [m]."""
        pts = [o.vertices for o in self.objects]
        if self.start is not None:
            pts.append(np.array([[self.start.x, self.start.y]]))
        if not pts:
            return (-margin, -margin, margin, margin)
        a = np.vstack(pts)
        lo, hi = a.min(axis=0) - margin, a.max(axis=0) + margin
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    # ---- output ------------------------------------------------------------------------

    def to_geojson(self) -> dict:
        """Return the world as a GeoJSON FeatureCollection dict (the file format)."""
        coll: dict[str, Any] = {"type": "FeatureCollection", "name": self.name}
        coll["sun"] = self.sun.model_dump()
        if self.start is not None:
            coll["start"] = self.start.model_dump(exclude_none=True)
        if self.weather is not None:
            coll["weather"] = self.weather.model_dump()
        if self.actors:
            coll["actors"] = list(self.actors)
        if self.terrain is not None:
            coll["terrain"] = self.terrain.model_dump()
        feats = [o.to_feature() for o in self.objects]
        feats += [n.to_feature() for n in self.nodes]
        feats += [e.to_feature() for e in self.edges]
        coll["features"] = feats
        return coll

    def save(self, path: str | Path) -> Path:
        """Write the world as GeoJSON to `path` (deterministic: one feature per line)."""
        path = Path(path)
        coll = self.to_geojson()
        feats = coll.pop("features")
        head = json.dumps(coll, sort_keys=False)[:-1]
        body = ",\n".join(json.dumps(_round(f), sort_keys=False) for f in feats)
        path.write_text(f'{head}, "features": [\n{body}\n]}}\n')
        return path

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(name={self.name!r}, objects={len(self.objects)}, nodes={len(self.nodes)}, "
            f"edges={len(self.edges)}, source={self.source!r})"
        )


def _round(obj: Any, nd: int = 4) -> Any:
    if isinstance(obj, float):
        r = round(obj, nd)
        return 0.0 if r == 0 else r
    if isinstance(obj, dict):
        return {k: _round(v, nd) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_round(v, nd) for v in obj]
    return obj


# --------------------------------------------------------------------------------------------
# parsing and validation


def world_path(name: str | Path, *, kind: Literal["world", "map"] = "world") -> Path:
    """Resolve a world name ("campus") or a file path to a file (worlds/<name>.<kind>.geojson)."""
    p = Path(name)
    if p.suffix in (".geojson", ".json") or p.exists():
        return p
    candidate = WORLDS_DIR / f"{name}.{kind}.geojson"
    if not candidate.exists():
        known = sorted({q.name.split(".")[0] for q in WORLDS_DIR.glob(f"*.{kind}.geojson")})
        raise FileNotFoundError(f"no {kind} file for {str(name)!r}: {candidate} does not exist; known: {known}")
    return candidate


def load_map_file(path: str | Path, *, kind: Literal["world", "map"] = "map", factory: Callable[..., Any] | None = None) -> Any:
    """Load and validate a world or map file (a name like "campus" or a path); raise `WorldFileError`.

    `factory` builds the result from the parsed parts (default `MapFile`).
    """
    p = world_path(path, kind=kind)
    try:
        text = p.read_text()
    except OSError as exc:
        raise WorldFileError(str(p), [Problem(message=f"cannot read file: {exc}")]) from None
    return parse_map_file(text, source=str(p), factory=factory)


def parse_map_file(text: str | dict, *, source: str = "<string>", factory: Callable[..., Any] | None = None) -> Any:
    """Parse and validate GeoJSON text (or an already-decoded dict); raise `WorldFileError`.

    `factory` builds the result from the parsed parts (default `MapFile`).
    """
    if isinstance(text, dict):
        data = text
    else:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise WorldFileError(source, [Problem(message=f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}")]) from None
    problems: list[Problem] = []
    if not isinstance(data, dict) or data.get("type") != "FeatureCollection":
        raise WorldFileError(source, [Problem(message='top level must be a GeoJSON object with "type": "FeatureCollection"')])
    feats = data.get("features")
    if not isinstance(feats, list):
        raise WorldFileError(source, [Problem(field="features", message="must be a list of Feature objects")])
    name = data.get("name")
    if not isinstance(name, str) or not name:
        problems.append(Problem(field="name", message="collection needs a non-empty string \"name\""))
        name = "unnamed"
    sun = None
    if "sun" in data:
        try:
            sun = Sun.model_validate(data["sun"])
        except ValidationError as exc:
            problems += _pyd_problems(exc, None, None, "sun")
    start = None
    if "start" in data:
        try:
            start = StartPose.model_validate(data["start"])
        except ValidationError as exc:
            problems += _pyd_problems(exc, None, None, "start")
    weather = None
    if "weather" in data:
        try:
            weather = Weather.model_validate(data["weather"])
        except ValidationError as exc:
            problems += _pyd_problems(exc, None, None, "weather")
    terrain, terrain_raster = None, None
    if "terrain" in data:
        try:
            terrain = TerrainRef.model_validate(data["terrain"])
        except ValidationError as exc:
            problems += _pyd_problems(exc, None, None, "terrain")
        else:
            base = Path(source).parent if Path(source).is_file() else Path.cwd()
            try:
                terrain_raster = load_terrain(base / terrain.file)
            except TerrainFileError as exc:
                problems.append(Problem(field="terrain.file", message=str(exc)))
                terrain = None
    actors = data.get("actors", [])
    if not isinstance(actors, list) or not all(isinstance(a, dict) for a in actors):
        problems.append(Problem(field="actors", message="must be a list of actor objects ({\"id\", \"kind\", \"path\", …})"))
        actors = []

    objects: list[WorldObject] = []
    nodes: list[PathNode] = []
    edges: list[PathEdge] = []
    seen: dict[str, int] = {}
    failed: set[str] = set()
    for i, f in enumerate(feats):
        fid = None
        if isinstance(f, dict) and isinstance(f.get("properties"), dict):
            raw = f["properties"].get("id")
            fid = raw if isinstance(raw, str) else None
        try:
            item = _parse_feature(i, f)
        except _FeatureProblems as exc:
            problems += exc.problems
            if fid is not None:
                failed.add(fid)
            continue
        if item.id in seen:
            problems.append(Problem(index=i, feature_id=fid, field="properties.id", message=f"duplicate id (first used by feature #{seen[item.id]})"))
            continue
        seen[item.id] = i
        if isinstance(item, WorldObject):
            objects.append(item)
        elif isinstance(item, PathNode):
            nodes.append(item)
        else:
            edges.append(item)
    # broken references (except to features already reported as broken), with their feature index
    for p in _cross_check(objects, nodes, edges, start, ignore=failed):
        if p.index is None and p.feature_id in seen:
            p = p.model_copy(update={"index": seen[p.feature_id]})
        problems.append(p)
    if problems:
        raise WorldFileError(source, problems)
    extra: dict[str, Any] = {"actors": actors} if actors else {}
    if terrain is not None:
        extra.update(terrain=terrain, terrain_raster=terrain_raster)
    return (factory or MapFile)(name=name, objects=objects, nodes=nodes, edges=edges, sun=sun, start=start, source=source,
                                weather=weather, **extra)


class _FeatureProblems(WireError):
    def __init__(self, problems: list[Problem]):
        self.problems = problems


def _pyd_problems(exc: ValidationError, index: int | None, fid: str | None, prefix: str) -> list[Problem]:
    out = []
    for e in exc.errors():
        loc = ".".join(str(x) for x in e["loc"])
        loc = loc.replace("from_", "from")
        msg = e["msg"]
        if e["type"] == "missing":
            msg = "required field is missing"
        elif e["type"] == "extra_forbidden":
            msg = "unknown field (typo?)"
        elif "input" in e:
            got = repr(e["input"])
            msg = f"{msg} (got {got if len(got) <= 120 else got[:117] + '...'})"
        out.append(Problem(index=index, feature_id=fid, field=f"{prefix}.{loc}" if loc else prefix, message=msg))
    return out


def _coords2(c: Any) -> tuple[float, float]:
    if not isinstance(c, (list, tuple)) or len(c) < 2 or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in c[:2]):
        raise ValueError(f"a position must be [x, y] numbers, got {c!r}")
    x, y = float(c[0]), float(c[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"a position must be finite, got {c!r}")
    return (x, y)


def _parse_feature(i: int, f: Any) -> WorldObject | PathNode | PathEdge:
    if not isinstance(f, dict) or f.get("type") != "Feature":
        raise _FeatureProblems([Problem(index=i, message='not a GeoJSON Feature (needs "type": "Feature")')])
    props = f.get("properties")
    if not isinstance(props, dict):
        raise _FeatureProblems([Problem(index=i, field="properties", message="missing or not an object")])
    fid = props.get("id") if isinstance(props.get("id"), str) else None
    if fid is None:
        raise _FeatureProblems([Problem(index=i, field="properties.id", message="missing or not a string")])
    kind = props.get("kind")
    geom = f.get("geometry")
    if not isinstance(geom, dict) or "type" not in geom or "coordinates" not in geom:
        raise _FeatureProblems([Problem(index=i, feature_id=fid, field="geometry", message="missing, or lacks type/coordinates")])
    gtype = geom["type"]
    coords = geom["coordinates"]

    def bad(field: str, msg: str) -> _FeatureProblems:
        return _FeatureProblems([Problem(index=i, feature_id=fid, field=field, message=msg)])

    if kind == "node":
        try:
            p = _NodeProps.model_validate(props)
        except ValidationError as exc:
            raise _FeatureProblems(_pyd_problems(exc, i, fid, "properties")) from None
        if gtype != "Point":
            raise bad("geometry.type", f"a node must be a Point, got {gtype!r}")
        if p.node_kind == "place" and not p.name:
            raise bad("properties.name", "a place node needs a name")
        try:
            x, y = _coords2(coords)
        except ValueError as exc:
            raise bad("geometry.coordinates", str(exc)) from None
        return PathNode(id=p.id, node_kind=p.node_kind, x=x, y=y, name=p.name, object_id=p.object)

    if kind == "edge":
        try:
            p = _EdgeProps.model_validate(props)
        except ValidationError as exc:
            raise _FeatureProblems(_pyd_problems(exc, i, fid, "properties")) from None
        if gtype != "LineString":
            raise bad("geometry.type", f"an edge must be a LineString, got {gtype!r}")
        if not isinstance(coords, list) or len(coords) < 2:
            raise bad("geometry.coordinates", "a LineString needs at least 2 positions")
        try:
            pts = tuple(_coords2(c) for c in coords)
        except ValueError as exc:
            raise bad("geometry.coordinates", str(exc)) from None
        if p.from_ == p.to:
            raise bad("properties.to", "an edge must join two different nodes")
        return PathEdge(id=p.id, from_node=p.from_, to_node=p.to, mode=p.mode, path_objects=p.path_objects, width=p.width, coords=pts, name=p.name)

    if kind not in OBJECT_KINDS:
        raise bad("properties.kind", f"unknown kind {kind!r}; expected 'node', 'edge' or one of {list(OBJECT_KINDS)}")
    try:
        p = _ObjectProps.model_validate(props)
    except ValidationError as exc:
        raise _FeatureProblems(_pyd_problems(exc, i, fid, "properties")) from None
    if p.markings and kind != "road":
        raise bad("properties.markings", f"only road objects take markings, not a {kind}")
    if p.shape.type not in SHAPES_BY_KIND[kind]:
        raise bad("properties.shape.type", f"a {kind} cannot have shape {p.shape.type!r}; allowed: {list(SHAPES_BY_KIND[kind])}")
    cost = math.inf if p.cost is None else float(p.cost)
    if not (cost >= 0.0) or math.isnan(cost):
        raise bad("properties.cost", f"must be >= 0 (omit it or use null for non-traversable), got {p.cost!r}")
    if p.role == "path" and not math.isfinite(cost):
        raise bad("properties.cost", "a path object needs a finite cost")
    if isinstance(p.shape, (SlopeShape, StairsShape)):
        if not all(math.isfinite(v) for v in (p.shape.rise, p.shape.axis_deg, p.shape.z0)):
            raise bad("properties.shape", "rise, axis_deg and z0 must be finite")
    if gtype == "Point":
        try:
            c = _coords2(coords)
        except ValueError as exc:
            raise bad("geometry.coordinates", str(exc)) from None
        if p.radius is None or not (p.radius > 0) or not math.isfinite(p.radius):
            raise bad("properties.radius", f"a Point object needs a footprint radius > 0 [m], got {p.radius!r}")
        if isinstance(p.shape, (SlopeShape, StairsShape, FlatShape)):
            raise bad("properties.shape.type", f"shape {p.shape.type!r} needs a Polygon geometry")
        if isinstance(p.shape, TreeShape):
            if abs(p.radius - p.shape.trunk_radius) > 1e-6:
                raise bad("properties.radius", f"a tree's radius is its trunk radius: {p.radius} != shape.trunk_radius {p.shape.trunk_radius}")
            if p.shape.crown_base >= p.shape.height:
                raise bad("properties.shape.crown_base", "must be below the tree height")
        return WorldObject(
            id=p.id, kind=kind, role=p.role, cost=cost, colour=p.colour, appearance=p.appearance, shape=p.shape,
            name=p.name, center=c, radius=float(p.radius),
        )
    if gtype != "Polygon":
        raise bad("geometry.type", f"an object must be a Polygon or a Point, got {gtype!r}")
    if p.radius is not None:
        raise bad("properties.radius", "only Point objects take a radius")
    if isinstance(p.shape, (TreeShape, PostShape)):
        raise bad("properties.shape.type", f"shape {p.shape.type!r} needs a Point geometry")
    if not isinstance(coords, list) or len(coords) == 0:
        raise bad("geometry.coordinates", "a Polygon needs one linear ring")
    if len(coords) > 1:
        raise bad("geometry.coordinates", "polygons with holes are not supported: give one ring")
    ring = coords[0]
    if not isinstance(ring, list):
        raise bad("geometry.coordinates", "a Polygon ring must be a list of positions")
    try:
        pts = [_coords2(c) for c in ring]
    except ValueError as exc:
        raise bad("geometry.coordinates", str(exc)) from None
    if len(pts) < 4 or pts[0] != pts[-1]:
        raise bad("geometry.coordinates", "a Polygon ring needs >= 4 positions and must be closed (first == last)")
    pts = pts[:-1]
    import shapely

    poly = shapely.Polygon(pts)
    if not poly.is_valid or poly.area <= 0.0:
        reason = shapely.is_valid_reason(poly)
        raise bad("geometry.coordinates", f"invalid polygon ({reason}; area {poly.area:.3g} m^2)")
    return WorldObject(
        id=p.id, kind=kind, role=p.role, cost=cost, colour=p.colour, appearance=p.appearance, shape=p.shape,
        name=p.name, polygon=tuple(pts), markings=p.markings,
    )


def _cross_check(
    objects: tuple[WorldObject, ...] | list[WorldObject],
    nodes: tuple[PathNode, ...] | list[PathNode],
    edges: tuple[PathEdge, ...] | list[PathEdge],
    start: StartPose | None,
    ignore: set[str] = frozenset(),  # type: ignore[assignment]
) -> list[Problem]:
    """Check references between features: edge ends, path objects, names, start node (ids in `ignore` count as present)."""
    problems: list[Problem] = []
    obj_by_id = {o.id: o for o in objects}
    node_by_id = {n.id: n for n in nodes}
    ids: dict[str, str] = {}
    for coll, label in ((objects, "object"), (nodes, "node"), (edges, "edge")):
        for item in coll:
            if item.id in ids:
                problems.append(Problem(feature_id=item.id, field="properties.id", message=f"duplicate id ({ids[item.id]} and {label})"))
            ids[item.id] = label
    names: dict[str, str] = {}
    for n in nodes:
        if n.name is not None:
            if n.name in names:
                problems.append(Problem(feature_id=n.id, field="properties.name", message=f"place name {n.name!r} also used by node {names[n.name]!r}"))
            names[n.name] = n.id
        if n.object_id is not None and n.object_id not in obj_by_id and n.object_id not in ignore:
            problems.append(Problem(feature_id=n.id, field="properties.object", message=f"unknown object {n.object_id!r}"))
    for e in edges:
        for end, nid, pt in (("from", e.from_node, e.coords[0]), ("to", e.to_node, e.coords[-1])):
            node = node_by_id.get(nid)
            if node is None:
                if nid not in ignore:
                    problems.append(Problem(feature_id=e.id, field=f"properties.{end}", message=f"unknown node {nid!r}"))
                continue
            gap = math.hypot(pt[0] - node.x, pt[1] - node.y)
            if gap > EDGE_END_TOLERANCE:
                problems.append(Problem(feature_id=e.id, field="geometry.coordinates", message=f"{end} end is {gap:.2f} m from node {nid!r} (max {EDGE_END_TOLERANCE} m)"))
        for oid in e.path_objects:
            o = obj_by_id.get(oid)
            if o is None:
                if oid not in ignore:
                    problems.append(Problem(feature_id=e.id, field="properties.path_objects", message=f"unknown object {oid!r}"))
            elif not o.traversable:
                problems.append(Problem(feature_id=e.id, field="properties.path_objects", message=f"object {oid!r} ({o.kind}) is not traversable"))
    if start is not None and start.node is not None and start.node not in node_by_id and start.node not in ignore:
        problems.append(Problem(field="start.node", message=f"unknown node {start.node!r}"))
    return problems
