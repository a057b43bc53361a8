"""The features of a world or map file: objects (an area or a round footprint), path-graph nodes and edges, the start.

Frame: `world` (x east [m], y north [m], z up [m]).
"""

from __future__ import annotations

import math
from functools import cached_property
from typing import Any, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict

from wire.mapfile.appearance import Appearance, MapColour, Marking
from wire.mapfile.kinds import KINDS, EdgeMode
from wire.mapfile.shapes import FlatShape, PostShape, PrismShape, SlopeShape, StairsShape, TreeShape
from wire.se2 import Pose2D, PoseFields

__all__ = ["StartPose", "WorldObject", "PathNode", "PathEdge"]

_FROZEN = ConfigDict(frozen=True, extra="forbid")


class StartPose(PoseFields, BaseModel):
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

    @classmethod
    def from_pose2d(cls, pose: Pose2D | Any, **fields: Any) -> "StartPose":
        """Return the start at `pose` (a Pose2D, or (x [m], y [m], yaw [rad])), its yaw kept in degrees; `fields`: `node`."""
        p = pose if isinstance(pose, Pose2D) else Pose2D.from_array(pose)
        return cls(x=p.x, y=p.y, yaw_deg=math.degrees(p.yaw), **fields)


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
