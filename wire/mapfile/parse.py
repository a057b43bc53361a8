"""Reading world and map files: a name or a path to a file, GeoJSON text to a validated `MapFile`, every problem named.

Each feature is checked by itself (its properties, its geometry, what its kind allows), then the
references between features (`wire.mapfile.references`); a file with any problem raises one
`WorldFileError` listing them all, each with its feature index, id and field.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Callable, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from wire.errors import WireError
from wire.mapfile.appearance import Appearance, MapColour, Marking, Sun, Weather
from wire.mapfile.collection import MapFile
from wire.mapfile.features import PathEdge, PathNode, StartPose, WorldObject
from wire.mapfile.kinds import OBJECT_KINDS, SHAPES_BY_KIND, EdgeMode
from wire.mapfile.problems import Problem, WorldFileError
from wire.mapfile.references import cross_check
from wire.mapfile.shapes import FlatShape, PostShape, Shape, SlopeShape, StairsShape, TreeShape
from wire.terrainfile import TerrainFileError, TerrainRef, load_terrain

__all__ = ["WORLDS_DIR", "WORLD_ONLY_FIELDS", "world_path", "load_map_file", "parse_map_file"]

#: Directory holding the shipped world and map files.
WORLDS_DIR = Path(__file__).resolve().parents[2] / "worlds"


_FROZEN = ConfigDict(frozen=True, extra="forbid")


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
    return parse_map_file(text, source=str(p), factory=factory, kind=kind)


#: What only a world says (how things look, what moves, the weather): a map file holding one is refused.
WORLD_ONLY_FIELDS = ("weather", "actors", "properties.appearance", "properties.markings")


def _world_only(data: dict) -> list[Problem]:
    """Return one problem naming the world-only fields of a decoded file (`WORLD_ONLY_FIELDS`) and where the first is."""
    found = [k for k in ("weather", "actors") if k in data]
    first: tuple[int, str | None, str] | None = None
    for k in ("appearance", "markings"):
        n = 0
        for i, f in enumerate(data.get("features") or []):
            props = f.get("properties") if isinstance(f, dict) else None
            if isinstance(props, dict) and k in props:
                n += 1
                if first is None or i < first[0]:
                    first = (i, props.get("id") if isinstance(props.get("id"), str) else None, f"properties.{k}")
        if n:
            found.append(f"{k} ({n} features)")
    if not found:
        return []
    where = dict(index=first[0], feature_id=first[1], field=first[2]) if first and not data.keys() & {"weather", "actors"} else {}
    return [Problem(**where, message=f"world-only fields, which a map never states: {', '.join(found)}; is this a world file?")]


def parse_map_file(text: str | dict, *, source: str = "<string>", factory: Callable[..., Any] | None = None,
                   kind: Literal["world", "map"] = "world") -> Any:
    """Parse and validate GeoJSON text (or an already-decoded dict); raise `WorldFileError`.

    `factory` builds the result from the parsed parts (default `MapFile`); a `kind="map"` file holding
    a world-only field (`WORLD_ONLY_FIELDS`) is refused.
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
    if kind == "map" and (world_only := _world_only(data)):
        raise WorldFileError(source, world_only)
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
    for p in cross_check(objects, nodes, edges, start, ignore=failed):
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
