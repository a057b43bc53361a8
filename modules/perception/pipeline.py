"""One PERCEPTION cycle on one frame: monitor decisions, PATCH MAKER, OBJECT FINDER, POSITION CALIBRATOR.

Seed: Sidewalk 1986 §3.3 — "It progresses in order of segmentation, object finding, and position
calibration." Pure: no network; the process in `module.py` feeds it frames and driving units.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
import shapely
from shapely.geometry import Polygon as ShapelyPolygon
from shapely.ops import unary_union

from modules.perception.calibrator import CalibrationError, CalibrationResult, EdgeObservation, PointObservation, calibrate
from modules.perception.column_mean import column_mean
from modules.perception.patch_maker import (
    ColourModel, Segmentation, SegmentationParams, Segmented, classify_colours, colour_mask, make_segmentation, patches_of, segment_range,
)
from modules.perception.patch_maker.range_seg import SurfaceFeatures
from modules.perception.image import ColoredRangeImage
from modules.perception.monitor import (
    ResolutionTable, ViewPlan, colour_model_for, colour_training, segmentation_params, select_segmentation,
)
from modules.perception.object_finder import FoundObject, find_objects
from modules.perception.predicted import PredictedObject, class_key, predict, visible_regions
from modules.parallel import VisionPool
from modules.vocabulary import MapObject

__all__ = ["PipelineOutput", "PerceptionPipeline", "CycleSetup", "CycleHead", "cycle_head", "cycle_tail", "edge_observations"]


@dataclass(frozen=True)
class PipelineOutput:
    """What one cycle produced; polygons in the vehicle frame at capture, the fix in the world frame."""

    method: Segmentation
    plan: ViewPlan
    segmented: Segmented
    found: tuple[FoundObject, ...]
    navigable: ShapelyPolygon | None
    calibration: CalibrationResult | None
    failure: str
    fix_note: str
    seconds: float


def _densify(ring: np.ndarray, flags: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample points every `step` [m] along edges whose both ends are flagged; return points and outward normals."""
    x, y = ring[:, 0], ring[:, 1]
    ccw = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) > 0
    pts, nrm = [], []
    for i in range(len(ring)):
        j = (i + 1) % len(ring)
        if not (flags[i] and flags[j]):
            continue
        a, b = ring[i], ring[j]
        d = b - a
        ln = float(np.hypot(*d))
        if ln < 1e-6:
            continue
        n = np.array([d[1], -d[0]]) / ln
        if not ccw:
            n = -n
        k = max(1, int(ln / step))
        for t in (np.arange(k) + 0.5) / k:
            pts.append(a + t * d)
            nrm.append(n)
    if not pts:
        return np.zeros((0, 2)), np.zeros((0, 2))
    return np.asarray(pts), np.asarray(nrm)


def _outline_samples(p, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Return object-edge points of a patch's outline about `step` [m] apart, with outward unit normals."""
    if p.boundary is None or p.boundary_flags is None or len(p.boundary) < 4:
        return _densify(np.asarray(p.polygon), np.asarray(p.edge_flags, bool), step)
    b = p.boundary
    x, y = b[:, 0], b[:, 1]
    ccw = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) > 0
    tangent = np.roll(b, -2, axis=0) - np.roll(b, 2, axis=0)
    ln = np.linalg.norm(tangent, axis=1)
    ok = p.boundary_flags & (ln > 1e-6)
    n = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1) / np.maximum(ln, 1e-9)[:, None]
    if not ccw:
        n = -n
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    # thin to about one sample per `step` along the outline
    seg = np.linalg.norm(np.diff(b, axis=0, append=b[:1]), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    keep = idx[np.concatenate([[True], np.diff(np.floor(s[idx] / step)) > 0])]
    return b[keep], n[keep]


def _segments(region) -> np.ndarray:
    """Return (M, 2, 2) edges of a (multi)polygon, oriented so the region lies on each edge's left."""
    polys = [region] if region.geom_type == "Polygon" else [g for g in getattr(region, "geoms", []) if g.geom_type == "Polygon"]
    segs = []
    for poly in polys:
        poly = shapely.geometry.polygon.orient(poly, sign=1.0)
        for ring in [poly.exterior, *poly.interiors]:
            c = np.asarray(ring.coords)
            segs.append(np.stack([c[:-1], c[1:]], axis=1))
    return np.concatenate(segs) if segs else np.zeros((0, 2, 2))


def edge_observations(
    found: tuple[FoundObject, ...] | list[FoundObject],
    predicted: list[PredictedObject] | tuple[PredictedObject, ...] | None = None,
    *,
    ids: np.ndarray | None = None,
    xyz: np.ndarray | None = None,
    step: float = 0.3,
    inner: float = 0.25,
    trunk_height: float = 1.5,
    method: Segmentation = Segmentation.COLORED_RANGE,
) -> tuple[list[EdgeObservation], list[PointObservation]]:
    """Turn found objects into calibrator observations.

    Ground objects: the object-edge points of their patches, grouped by class (colour type and
    surface) and paired with the edges of that class's predicted visible region. Round objects
    (trunks, posts): the centre of the patch's low points (below `trunk_height` [m]), pushed back by
    the radius since the scanner sees only the near side.
    """
    predicted = list(predicted) if predicted is not None else [f.predicted for f in found]
    regions = visible_regions(predicted, method)
    edges: list[EdgeObservation] = []
    points: list[PointObservation] = []
    by_class: dict[tuple, list[FoundObject]] = {}
    for f in found:
        obj = f.predicted.obj
        if f.predicted.center is not None:
            if obj.center is None:
                continue
            best = max(f.patches, key=lambda p: p.pixels)
            c = np.asarray(best.centroid, dtype=np.float64)
            if ids is not None and xyz is not None:
                m = (ids == best.id) & (xyz[..., 2] < trunk_height)
                if m.sum() >= 3:
                    c = column_mean(xyz[m][:, :2].astype(np.float64))
            r = float(np.sqrt(f.predicted.footprint.area / np.pi))
            c = c + (math.pi / 4) * r * c / max(float(np.linalg.norm(c)), 1e-6)
            points.append(PointObservation(point=(float(c[0]), float(c[1])), target=(float(obj.center[0]), float(obj.center[1]))))
            continue
        if f.predicted.ground:
            by_class.setdefault(class_key(f.predicted, method), []).append(f)
    for key, fs in by_class.items():
        region = regions.get(key)
        if region is None or region.is_empty:
            continue
        segs = _segments(region)
        if len(segs) == 0:
            continue
        outline = unary_union([f.outline for f in fs])
        boundary = outline.boundary
        all_p, all_n = [], []
        for f in fs:
            for p in f.patches:
                pts, nrm = _outline_samples(p, step)
                if len(pts) == 0:
                    continue
                keep = shapely.distance(shapely.points(pts), boundary) <= inner  # not between two patches of the class
                all_p.append(pts[keep])
                all_n.append(nrm[keep])
        if all_p:
            P, N = np.vstack(all_p), np.vstack(all_n)
            if len(P):
                edges.append(EdgeObservation(points=P, normals=N, segments=segs))
    return edges, points


class PerceptionPipeline:
    """Run PERCEPTION cycles; keeps the adapted colour classes and the measured processing times.

    With a `pool` of several vision workers the per-pixel stages (registration by the caller's
    `colored_range_image(frame, pool=pipeline.pool)`, colour classification) run in stripes over its
    processes; the results are the same as in one process.
    """

    def __init__(
        self,
        table: ResolutionTable | None = None,
        base: SegmentationParams = SegmentationParams(),
        speed: float = 1.0,
        pool: VisionPool | None = None,
    ) -> None:
        """Start with a resolution table (sensor geometry), base segmentation parameters, the desired speed [m/s] and a vision pool."""
        self.table = table or ResolutionTable()
        self.speed = speed
        self.base = base
        self.pool = pool
        self._models: dict[tuple[str, ...], ColourModel] = {}
        # per set of predicted objects: segmentation parameters, names of the colour classes
        self._params: dict[tuple, SegmentationParams] = {}
        self._model_keys: dict[tuple[MapObject, ...], tuple[str, ...]] = {}

    def params_for(self, objects: tuple[MapObject, ...]) -> SegmentationParams:
        """Return the segmentation parameters for these predicted objects (§3.3.4), worked out once per set of objects."""
        key = (tuple(objects), self.base)
        if key not in self._params:
            if len(self._params) >= 256:
                self._params.pop(next(iter(self._params)))
            self._params[key] = segmentation_params(objects, self.base)
        return self._params[key]

    def colour_model_for(self, objects: tuple[MapObject, ...]) -> ColourModel:
        """Return fresh colour classes for these predicted objects (the map's colour types and nominal colours)."""
        return colour_model_for(objects)

    def _adapted_model(self, objects: tuple[MapObject, ...]) -> ColourModel:
        key = self._model_keys.get(tuple(objects))
        if key is None or key not in self._models:
            fresh = self.colour_model_for(objects)
            key = tuple(sorted(c.name for c in fresh.classes))
            if len(self._model_keys) >= 256:
                self._model_keys.pop(next(iter(self._model_keys)))
            self._model_keys[tuple(objects)] = key
            if key not in self._models:
                self._models[key] = fresh
        return self._models[key]

    def segment(
        self,
        work: ColoredRangeImage,
        objects: tuple[MapObject, ...],
        prior_pose: tuple[float, float, float],
        method: Segmentation,
        *,
        error_allowance: float = 0.5,
        model: ColourModel | None = None,
        predicted: list[PredictedObject] | None = None,
    ) -> Segmented:
        """Run the PATCH MAKER on one frame: colour classes fitted to the pixels the predicted objects vouch for.

        `model` defaults to the classes this pipeline keeps adapting for these objects; the pixels
        that teach them lie inside a predicted ground object at least `error_allowance` [m] from its edge.
        """
        params = self.params_for(objects)
        if method is Segmentation.RANGE:
            return make_segmentation(method, work, params, pool=self.pool)
        model = model if model is not None else self._adapted_model(objects)
        predicted = predicted if predicted is not None else predict(objects, prior_pose)
        xy = work.xyz[..., :2] if method is Segmentation.COLORED_RANGE else work.ground_xy
        training = colour_training(predicted, xy, work.valid, model.types, prior_pose, error_allowance)
        return make_segmentation(method, work, params, model, training=training, pool=self.pool)

    def process(
        self,
        img: ColoredRangeImage,
        objects: tuple[MapObject, ...],
        prior_pose: tuple[float, float, float],
        *,
        error_allowance: float = 0.5,
        method: Segmentation | None = None,
        step: int | None = None,
    ) -> PipelineOutput:
        """Segment, find the predicted objects and fix the pose (world←vehicle) for one frame."""
        t0 = time.perf_counter()
        setup = self.setup(objects, error_allowance, method, step)
        head = cycle_head(img, setup, objects, prior_pose, error_allowance)
        colour_lab = self.colour_step(setup, objects, head.work.rgb, head.mask, head.training)
        out = cycle_tail(head, colour_lab, setup, prior_pose, error_allowance)
        dt = time.perf_counter() - t0
        self.table.record(setup.plan.step, dt)
        return replace(out, seconds=dt)

    def setup(self, objects: tuple[MapObject, ...], error_allowance: float, method: Segmentation | None = None,
              step: int | None = None) -> "CycleSetup":
        """Return what the monitor decides for one cycle before it looks at the frame: method, view plan, parameters."""
        method, plan = self.method_and_plan(objects, error_allowance, method, step)
        types = () if method is Segmentation.RANGE else self._adapted_model(objects).types
        return CycleSetup(method, plan, self.params_for(objects), types, self.table.sensor.x_offset)

    def method_and_plan(self, objects: tuple[MapObject, ...], error_allowance: float, method: Segmentation | None = None,
                        step: int | None = None) -> tuple[Segmentation, ViewPlan]:
        """Return the segmentation method and the view plan (resolution step, distance) of one cycle."""
        method = method or select_segmentation(objects)
        if method is not Segmentation.RANGE and not any(o.colour is not None for o in objects):
            method = Segmentation.RANGE  # nothing predicted says what colour to look for: range alone
        plan = self.table.plan(error_allowance, self.speed)
        return method, plan if step is None else replace(plan, step=step)

    def colour_step(self, setup: "CycleSetup", objects: tuple[MapObject, ...], rgb: np.ndarray, mask: np.ndarray | None,
                    training: np.ndarray | None, *, striped: bool = True) -> np.ndarray | None:
        """Classify one frame's colours with the classes kept for these objects, adapting them (None for range alone).

        The one stage that carries state from frame to frame: frames must pass it in order. `striped`:
        classify in row stripes over the pool's workers (the same labels as in this process).
        """
        if setup.method is Segmentation.RANGE:
            return None
        assert mask is not None
        return classify_colours(setup.method, rgb, mask, setup.params, self._adapted_model(objects), training=training,
                                pool=self.pool if striped else None)


@dataclass(frozen=True)
class CycleSetup:
    """The monitor's decisions for one cycle: segmentation `method`, view `plan`, segmentation `params`,
    the colour `types` a colour label indexes (1-based; empty for range alone) and the laser's `x_offset` [m]."""

    method: Segmentation
    plan: ViewPlan
    params: SegmentationParams
    types: tuple[str, ...]
    x_offset: float


@dataclass(frozen=True)
class CycleHead:
    """What a cycle knows before classifying colours: the view-frame image `work`, the `predicted` objects,
    the colour `training` labels and `mask` (H, W) of the colour stage (None for range alone), and the
    range segmentation `surface` (labels (H, W) uint8, features; None for colour alone)."""

    work: ColoredRangeImage
    predicted: list[PredictedObject]
    training: np.ndarray | None
    mask: np.ndarray | None
    surface: tuple[np.ndarray, SurfaceFeatures] | None


def cycle_head(img: ColoredRangeImage, setup: CycleSetup, objects: tuple[MapObject, ...], prior_pose: tuple[float, float, float],
               error_allowance: float) -> CycleHead:
    """Cut one frame to the view frame, predict the objects, label the colour training pixels and segment the range.

    Depends on this frame alone (no state carried between frames).
    """
    method, plan = setup.method, setup.plan
    work = img.subsample(plan.step)
    # the view frame: nothing beyond the perception distance
    x = work.xyz[..., 0] if method is not Segmentation.COLOUR else work.ground_xy[..., 0]
    inside = work.valid & np.isfinite(x) & (x <= plan.distance + setup.x_offset)
    work = replace(work, valid=inside)
    predicted = predict(objects, prior_pose)
    training = mask = None
    if method is not Segmentation.RANGE:
        xy = work.xyz[..., :2] if method is Segmentation.COLORED_RANGE else work.ground_xy
        training = colour_training(predicted, xy, work.valid, setup.types, prior_pose, error_allowance)
        mask = colour_mask(method, work)
    surface = None if method is Segmentation.COLOUR else segment_range(work.xyz, work.range_m, work.valid, setup.params.range)
    return CycleHead(work, predicted, training, mask, surface)


def cycle_tail(head: CycleHead, colour_lab: np.ndarray | None, setup: CycleSetup, prior_pose: tuple[float, float, float],
               error_allowance: float) -> PipelineOutput:
    """Make the patches, find the predicted objects and fix the pose of one frame from its colour labels (`seconds` 0)."""
    method, work, predicted = setup.method, head.work, head.predicted
    seg = patches_of(method, work, setup.params, colour_lab, setup.types, head.surface)
    found, _ = find_objects(seg.patches, predicted, allowance=error_allowance + 0.5)
    nav_parts = [f.outline for f in found if f.predicted.obj.role == "path"]
    navigable = None
    if nav_parts:
        u = unary_union(nav_parts)
        if u.geom_type == "MultiPolygon":
            u = max(u.geoms, key=lambda g: g.area)
        navigable = u if u.geom_type == "Polygon" and not u.is_empty else None
    failure = ""
    if not any(f.predicted.obj.role == "path" for f in found) and any(p.obj.role == "path" for p in predicted):
        failure = f"no predicted path object found among {len(seg.patches.patches)} {method.value} patches"
    cal = None
    note = ""
    edges, points = edge_observations(found, predicted, ids=seg.patches.ids, xyz=work.xyz, method=method)
    if edges or points:
        try:
            cal = calibrate(edges, points, prior_pose, gate=error_allowance + 1.5, final_gate=max(0.4, error_allowance))
        except CalibrationError as exc:
            note = str(exc)
    else:
        note = "no object edges or landmarks to calibrate with"
    return PipelineOutput(method, setup.plan, seg, tuple(found), navigable, cal, failure, note, 0.0)
