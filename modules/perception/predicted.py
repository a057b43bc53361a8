"""Predicted objects in the vehicle frame: what the PERCEPTION MONITOR puts into the WORKING MEMORY.

Seed: Sidewalk 1986 §3.2.2 — predicted object shape and features (colour, surface type, shape).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from shapely.geometry import Point as ShapelyPoint
from shapely.geometry import Polygon as ShapelyPolygon
from shapely.ops import unary_union

from modules.perception.patch_maker import Segmentation, SurfaceType
from modules.vocabulary import MapObject

__all__ = [
    "PredictedObject", "predict", "world_to_vehicle", "vehicle_to_world", "expected_surfaces", "is_ground_kind",
    "class_key", "visible_regions",
]

_GROUND_SHAPES = ("flat", "slope", "stairs")


def world_to_vehicle(pts: np.ndarray, pose: tuple[float, float, float]) -> np.ndarray:
    """Map (N, 2) world points [m] into the vehicle frame of `pose` = world←vehicle (x, y, yaw)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    d = np.asarray(pts, dtype=np.float64) - (x, y)
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def vehicle_to_world(pts: np.ndarray, pose: tuple[float, float, float]) -> np.ndarray:
    """Map (N, 2) vehicle-frame points [m] into the world frame with `pose` = world←vehicle (x, y, yaw)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    p = np.asarray(pts, dtype=np.float64)
    return np.stack([c * p[:, 0] - s * p[:, 1] + x, s * p[:, 0] + c * p[:, 1] + y], axis=1)


def is_ground_kind(obj: MapObject) -> bool:
    """Return whether the object is a ground surface (flat, slope or stairs) rather than something standing."""
    return obj.shape.type in _GROUND_SHAPES


def expected_surfaces(obj: MapObject) -> frozenset[int]:
    """Return the SurfaceType values range segmentation may give this object."""
    t = obj.shape.type
    if t == "flat":
        return frozenset({SurfaceType.FLAT})
    if t == "slope":
        return frozenset({SurfaceType.TILTED})
    if t == "stairs":
        return frozenset({SurfaceType.ROUGH})
    return frozenset({SurfaceType.VERTICAL, SurfaceType.ROUGH})


@dataclass(frozen=True)
class PredictedObject:
    """A map object as expected in the vehicle frame: footprint, colour type, expected surfaces."""

    obj: MapObject
    footprint: ShapelyPolygon  # vehicle frame [m]
    world_footprint: ShapelyPolygon  # world frame [m]
    colour_type: str | None
    surfaces: frozenset[int]
    center: tuple[float, float] | None  # round objects: vehicle-frame centre [m]

    @property
    def ground(self) -> bool:
        """Return whether this is a ground surface object."""
        return is_ground_kind(self.obj)


@functools.lru_cache(maxsize=1024)
def _footprint_world(obj: MapObject) -> ShapelyPolygon:
    """Return the object's footprint in the world frame [m] (kept per object: one and the same geometry every frame)."""
    if obj.polygon is not None:
        poly = ShapelyPolygon(obj.polygon)
        return poly if poly.is_valid else poly.buffer(0)
    assert obj.center is not None and obj.radius is not None
    r = obj.radius
    if obj.shape.type == "tree":
        r = obj.shape.trunk_radius  # type: ignore[union-attr]
    return ShapelyPoint(obj.center).buffer(max(r, 0.05), 16)


def predict(objects: tuple[MapObject, ...] | list[MapObject], pose: tuple[float, float, float]) -> list[PredictedObject]:
    """Put map objects into the vehicle frame of the prior pose (world←vehicle)."""
    out = []
    for o in objects:
        wf = _footprint_world(o)
        vf = ShapelyPolygon(world_to_vehicle(np.asarray(wf.exterior.coords), pose))
        center = None
        if o.center is not None:
            c = world_to_vehicle(np.asarray([o.center]), pose)[0]
            center = (float(c[0]), float(c[1]))
        ctype = o.colour.type if o.colour is not None else None
        out.append(PredictedObject(o, vf, wf, ctype, expected_surfaces(o), center))
    return out


def class_key(obj: PredictedObject, method: Segmentation = Segmentation.COLORED_RANGE) -> tuple:
    """Return what the segmentation can tell this object by: colour type, surface types, or both."""
    colour = obj.colour_type if method is not Segmentation.RANGE else None
    surfaces = tuple(sorted(obj.surfaces)) if method is not Segmentation.COLOUR else ()
    return (colour, surfaces)


#: Regions already worked out, per (method, (class, footprint) of each ground object); the footprints are
#: held with them, so the ids in a key stay those of the very geometries.
_REGIONS: dict[tuple, tuple[list, dict[tuple, object]]] = {}


def visible_regions(predicted: list[PredictedObject] | tuple[PredictedObject, ...],
                    method: Segmentation = Segmentation.COLORED_RANGE) -> dict[tuple, object]:
    """Return, per class the segmentation can tell apart, the world-frame region where that class shows.

    A large ground object (a lawn) is painted under the smaller ones that overlap it (the sidewalks
    crossing it), so each object shows only outside the smaller overlapping objects of another class.
    The regions depend on the world footprints alone, so each set of objects is worked out once.
    """
    ground = [p for p in predicted if p.ground]
    keys = [class_key(p, method) for p in ground]
    fps = [p.world_footprint for p in ground]
    memo = (method, tuple(zip(keys, map(id, fps))))
    if memo in _REGIONS:
        return dict(_REGIONS[memo][1])
    areas = [f.area for f in fps]
    regions: dict[tuple, list] = {}
    for i, (o, fp) in enumerate(zip(ground, fps)):
        covers = [fps[j] for j, q in enumerate(ground) if q is not o and keys[j] != keys[i]
                  and areas[j] < areas[i] and fps[j].intersects(fp)]
        vis = fp.difference(unary_union(covers)) if covers else fp
        regions.setdefault(keys[i], []).append(vis)
    out = {k: unary_union(v) for k, v in regions.items()}
    if len(_REGIONS) >= 64:
        _REGIONS.pop(next(iter(_REGIONS)))
    _REGIONS[memo] = (fps, out)
    return dict(out)
