"""Derive the map (what the robot is told) from the world (the truth) with a configurable error."""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.worldfile import (
    PathEdge,
    PathNode,
    SlopeShape,
    StairsShape,
    StartPose,
    World,
    WorldObject,
)

__all__ = ["MapError", "DEFAULT_MAP_ERROR", "NO_MAP_ERROR", "derive_map", "displaced_by_up_to", "map_for", "REMOVABLE_ROLES"]

#: Roles of objects that may be displaced or left out of the map (path objects never are).
REMOVABLE_ROLES = ("landmark", "obstacle")


class MapError(BaseModel):
    """How wrong the map is: a rigid offset [m] and rotation [deg] about the start, per-object errors.

    `displace_std` [m] is the per-axis standard deviation of independent displacements of landmark and
    obstacle objects, each displacement clipped to `displace_max` [m] when given; `missing_fraction` is
    the probability that such an object is absent from the map.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    offset_x: float = 0.0
    offset_y: float = 0.0
    rotation_deg: float = 0.0
    displace_std: float = Field(default=0.0, ge=0.0)
    displace_max: float | None = Field(default=None, ge=0.0)
    missing_fraction: float = Field(default=0.0, ge=0.0, le=1.0)

    @classmethod
    def scaled(cls, magnitude: float) -> "MapError":
        """Return the default error scaled by `magnitude` (0 = perfect map, 1 = default)."""
        d = DEFAULT_MAP_ERROR
        return cls(
            offset_x=d.offset_x * magnitude,
            offset_y=d.offset_y * magnitude,
            rotation_deg=d.rotation_deg * magnitude,
            displace_std=d.displace_std * magnitude,
            missing_fraction=min(1.0, d.missing_fraction * magnitude),
        )


def displaced_by_up_to(max_m: float) -> "MapError":
    """Return a map error that only moves landmarks and obstacles, each by at most `max_m` [m]."""
    return MapError(displace_std=max_m / 2.0, displace_max=max_m)


#: The small error shipped maps carry: 0.4 m offset, 0.3° rotation, 0.25 m object scatter, 5 % missing.
DEFAULT_MAP_ERROR = MapError(offset_x=0.3, offset_y=-0.25, rotation_deg=0.3, displace_std=0.25, missing_fraction=0.05)
NO_MAP_ERROR = MapError()


def derive_map(world: World, error: MapError, rng: np.random.Generator) -> World:
    """Return a map of `world`: rigidly moved by the offset/rotation about the start, objects scattered and dropped.

    Geometry stays in the `world` frame; the randomness comes only from `rng`.
    """
    if world.start is not None:
        pivot = np.array([world.start.x, world.start.y])
    else:
        xmin, ymin, xmax, ymax = world.bounds()
        pivot = np.array([(xmin + xmax) / 2, (ymin + ymax) / 2])
    th = math.radians(error.rotation_deg)
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    t = np.array([error.offset_x, error.offset_y])

    def move(p: np.ndarray) -> np.ndarray:
        return (np.asarray(p, float) - pivot) @ R.T + pivot + t

    def tup(a: np.ndarray) -> tuple[tuple[float, float], ...]:
        return tuple((round(float(x), 4), round(float(y), 4)) for x, y in a.reshape(-1, 2))

    objects: list[WorldObject] = []
    for o in world.objects:
        removable = o.role in REMOVABLE_ROLES
        # draw both numbers for every object so the stream does not depend on earlier outcomes
        drop = rng.random() < error.missing_fraction
        d = rng.normal(0.0, 1.0, size=2) * error.displace_std
        if error.displace_max is not None and (n := float(np.hypot(*d))) > error.displace_max:
            d *= error.displace_max / n
        if removable and drop:
            continue
        shift = d if removable else np.zeros(2)
        update: dict = {}
        if o.polygon is not None:
            update["polygon"] = tup(move(np.asarray(o.polygon)) + shift)
        else:
            update["center"] = tup(move(np.asarray(o.center)) + shift)[0]
        update["appearance"] = None  # a map states colour type and nominal colour, never how the surface looks
        if isinstance(o.shape, (SlopeShape, StairsShape)) and error.rotation_deg:
            update["shape"] = o.shape.model_copy(update={"axis_deg": o.shape.axis_deg + error.rotation_deg})
        # build a fresh object (model_copy would carry cached geometry of the original over)
        objects.append(WorldObject(**{**{f: getattr(o, f) for f in WorldObject.model_fields}, **update}))
    nodes: list[PathNode] = []
    for n in world.nodes:
        x, y = move(np.array([n.x, n.y]))
        nodes.append(n.model_copy(update={"x": round(float(x), 4), "y": round(float(y), 4)}))
    edges: list[PathEdge] = []
    for e in world.edges:
        edges.append(e.model_copy(update={"coords": tup(move(np.asarray(e.coords)))}))
    start = None
    if world.start is not None:
        sx, sy = move(np.array([world.start.x, world.start.y]))
        start = StartPose(x=round(float(sx), 4), y=round(float(sy), 4), yaw_deg=world.start.yaw_deg + error.rotation_deg, node=world.start.node)
    return World(name=world.name, objects=objects, nodes=nodes, edges=edges, sun=world.sun, start=start,
                 source=f"<map of {world.source}>", raster_res=world.raster_res)


def map_for(world: World, scale: float = 1.0, seed: int = 0) -> World:
    """Return the map of `world` with the default error scaled by `scale`, drawn from `seed`.

    The shipped `<name>.map.geojson` files are `map_for(world, 1.0, 0)`; so is what `sim serve` serves by default.
    """
    return derive_map(world, MapError.scaled(scale), np.random.default_rng(seed))
