"""OBJECT FINDER: match patches to predicted objects, first by symbol, then by geometry.

Seed: Sidewalk 1986 §3.2.2 — a WORKING MEMORY holds the patches (from the PATCH MAKER) and the predicted
objects (from the PERCEPTION MONITOR); one kind of rule identifies segments as parts of predicted objects
(colour type, surface type), the other finds the correspondence of predicted and detected polygons.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from shapely.geometry import Polygon as ShapelyPolygon
from shapely.ops import unary_union

from modules.perception.patch_maker import Patch, PatchSet
from modules.perception.predicted import PredictedObject

__all__ = ["Match", "FoundObject", "WorkingMemory", "symbolic_match", "geometric_score", "find_objects"]


@dataclass(frozen=True)
class Match:
    """One patch identified as part of one predicted object with a geometric score (0–1)."""

    patch_id: int
    object_id: str
    score: float


@dataclass(frozen=True)
class FoundObject:
    """A predicted object and the patches found for it; outline in the vehicle frame [m]."""

    predicted: PredictedObject
    patches: tuple[Patch, ...]
    outline: ShapelyPolygon
    score: float


@dataclass
class WorkingMemory:
    """The OBJECT FINDER's working memory: patches, predicted objects and the matches made so far."""

    patches: tuple[Patch, ...]
    predicted: tuple[PredictedObject, ...]
    matches: list[Match] = field(default_factory=list)


def symbolic_match(patch: Patch, obj: PredictedObject) -> bool:
    """Rule 1: a patch can be part of an object when its colour type and surface type agree."""
    if patch.surface is not None and patch.surface not in obj.surfaces:
        return False
    if obj.ground and patch.colour_type is not None and obj.colour_type is not None:
        return patch.colour_type == obj.colour_type
    if not obj.ground and patch.surface is None:
        return False  # standing objects need range to be seen
    return True


def geometric_score(patch: Patch, obj: PredictedObject, allowance: float, grown: ShapelyPolygon | None = None) -> float:
    """Rule 2: how well the patch lies where the object is predicted (0–1), within `allowance` [m]."""
    shape = patch.shape()
    if obj.center is not None:
        d = float(np.hypot(patch.centroid[0] - obj.center[0], patch.centroid[1] - obj.center[1]))
        reach = allowance + float(np.sqrt(max(obj.footprint.area, 1e-6) / np.pi)) + 0.3
        return max(0.0, 1.0 - d / reach)
    if shape.area <= 0:
        return 0.0
    if grown is None:
        grown = obj.footprint.buffer(allowance)
    if not shape.intersects(grown):
        return 0.0
    return float(shape.intersection(grown).area / shape.area)


def find_objects(
    patches: PatchSet,
    predicted: list[PredictedObject],
    allowance: float,
    min_score: float = 0.5,
) -> tuple[list[FoundObject], WorkingMemory]:
    """Run the symbolic then the geometric rules; each patch joins at most one object (the best score)."""
    wm = WorkingMemory(patches=patches.patches, predicted=tuple(predicted))
    grown = {id(o): o.footprint.buffer(allowance, 8) for o in predicted if o.center is None}
    for p in patches.patches:
        cands = [o for o in predicted if symbolic_match(p, o)]
        if not cands:
            continue
        best: Match | None = None
        # a patch may run over several adjoining objects of one kind (a T of sidewalks and their crossing):
        # it lies where predicted when the compatible objects together cover it
        areas = [o for o in cands if o.center is None]
        cover = 0.0
        shape = p.shape()
        if areas and shape.area > 0:
            together = unary_union([grown[id(o)] for o in areas])
            cover = float(shape.intersection(together).area / shape.area) if shape.intersects(together) else 0.0
        best_s = -1.0
        for obj in cands:
            s = geometric_score(p, obj, allowance, grown.get(id(obj)))
            ok = s >= min_score or (obj.center is None and s > 0.05 and cover >= min_score)
            if ok and s > best_s:
                best_s = s
                best = Match(p.id, obj.obj.object_id, s if obj.center is not None else max(s, cover))
        if best is not None:
            wm.matches.append(best)
    found = []
    for obj in predicted:
        ms = [m for m in wm.matches if m.object_id == obj.obj.object_id]
        if not ms:
            continue
        ps = tuple(patches.by_id(m.patch_id) for m in ms)
        outline = unary_union([p.shape().buffer(0) for p in ps])
        if outline.geom_type == "MultiPolygon":
            outline = max(outline.geoms, key=lambda g: g.area)
        if outline.is_empty or outline.geom_type != "Polygon":
            continue
        w = np.array([p.area_m2 for p in ps])
        score = float(np.dot([m.score for m in ms], w) / max(w.sum(), 1e-9))
        found.append(FoundObject(obj, ps, outline, score))
    return found, wm
