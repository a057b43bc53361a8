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

One concern a file: `kinds` (the vocabularies), `problems` (what is wrong, where), `appearance`
(colours, weather, markings, the sun), `shapes` (3-D shapes), `features` (objects, nodes, edges, the
start), `references` (the checks between features), `collection` (`MapFile`), `parse` (reading files).
Everything public is imported here: `from wire.mapfile import …` as before.
"""

from wire.mapfile.appearance import (
    COLOUR_TYPES, MARKING_COLOURS, Appearance, ColourStats, ColourType, MapColour, Marking, Sun, Weather,
)
from wire.mapfile.collection import MapFile
from wire.mapfile.features import PathEdge, PathNode, StartPose, WorldObject
from wire.mapfile.kinds import EDGE_MODES, KIND_PRIORITY, KINDS, NODE_KINDS, OBJECT_KINDS, ROLES, SHAPES_BY_KIND, EdgeMode
from wire.mapfile.parse import WORLD_ONLY_FIELDS, WORLDS_DIR, load_map_file, parse_map_file, world_path
from wire.mapfile.problems import Problem, WorldFileError
from wire.mapfile.references import EDGE_END_TOLERANCE
from wire.mapfile.shapes import FlatShape, PostShape, PrismShape, Shape, SlopeShape, StairsShape, TreeShape

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
    "WORLD_ONLY_FIELDS",
    "world_path",
    "WORLDS_DIR",
    "EDGE_END_TOLERANCE",
]
