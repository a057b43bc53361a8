"""Turn one PERCEPTION cycle into the vocabulary's `PerceptionResult` (world frame) for a driving unit.

Outlines and the navigable region are put into the world frame with the best pose the cycle knows:
the fix when it is a point, the prior moved onto the line when it is a line, else the prior.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import Polygon as ShapelyPolygon

from modules.perception.calibrator import CalibrationResult
from modules.perception.column_mean import column_mean
from modules.perception.image import ColoredRangeImage
from modules.perception.patch_maker import Segmentation, SurfaceType as ST
from modules.perception.pipeline import PipelineOutput
from modules.perception.predicted import vehicle_to_world
from modules.vocabulary import DetectedObject, DrivingUnitDescription, LineFix, PerceptionResult, PointFix, Pose

__all__ = ["SENSOR_MODE", "MIN_REGION_AREA", "COV_FLOOR", "LINE_COV_FLOOR", "best_pose", "position_fix", "world_ring", "build_result", "failed_result"]

#: Vocabulary name of each segmentation module.
SENSOR_MODE = {Segmentation.COLOUR: "colour", Segmentation.RANGE: "range", Segmentation.COLORED_RANGE: "colored-range"}

_SURFACE = {ST.FLAT: "flat", ST.TILTED: "slope", ST.ROUGH: "rough", ST.VERTICAL: "vertical"}

#: Smallest navigable region or outline worth reporting [m²]: anything smaller is a sliver, not a passage.
MIN_REGION_AREA = 0.05

#: Floor added to a point fix's covariance: map scatter and correlated edge errors ([m²], [m²], [rad²]).
#: Measured by `sidewalk perception eval --world campus --frames 40 --seed 1`: point fixes err by
#: 0.34 m (p50) and 0.42° / 2.2° (p50 / p95) against the truth, line fixes by 0.15 m across the line
#: and 0.34° / 0.66°; the floors make the stated uncertainty match that.
COV_FLOOR = np.diag([0.3**2, 0.3**2, math.radians(1.2) ** 2])
#: Floor added to a line fix's variances: across the line [m²] and heading [rad²].
LINE_COV_FLOOR = np.diag([0.2**2, 0.2**2, math.radians(0.5) ** 2])


def best_pose(cal: CalibrationResult | None, prior: tuple[float, float, float]) -> tuple[float, float, float]:
    """Return the pose world←vehicle to draw results with: the fix, or the prior moved onto the fix's line."""
    if cal is None:
        return prior
    if cal.kind == "point":
        return cal.pose
    d = np.array([math.cos(cal.line_direction), math.sin(cal.line_direction)])
    p0 = np.array(cal.pose[:2])
    on = p0 + d * float(np.dot(np.array(prior[:2]) - p0, d))
    return (float(on[0]), float(on[1]), cal.pose[2] if cal.yaw_known else prior[2])


def _ring(poly: ShapelyPolygon, pose: tuple[float, float, float]) -> tuple[tuple[float, float], ...]:
    pts = np.asarray(poly.exterior.coords)[:-1]
    w = vehicle_to_world(pts, pose)
    return tuple((round(x, 4), round(y, 4)) for x, y in w.tolist())


def _simple_ring(ring: tuple[tuple[float, float], ...], min_area: float) -> bool:
    """Return whether `ring` [m] is a simple polygon of at least `min_area` [m²] (what the blackboard accepts)."""
    if len(set(ring)) < 3:
        return False
    poly = ShapelyPolygon(ring)
    return bool(poly.is_valid and poly.area >= min_area)


def _largest_part(geom) -> ShapelyPolygon | None:
    """Return the largest polygon of a (multi)geometry, holes dropped, or None."""
    polys = [g for g in getattr(geom, "geoms", [geom]) if g.geom_type == "Polygon" and not g.is_empty]
    if not polys:
        polys = [g for p in getattr(geom, "geoms", []) for g in getattr(p, "geoms", []) if g.geom_type == "Polygon" and not g.is_empty]
    return ShapelyPolygon(max(polys, key=lambda g: g.area).exterior) if polys else None


def world_ring(poly, pose: tuple[float, float, float], min_area: float = MIN_REGION_AREA) -> tuple[tuple[float, float], ...] | None:
    """Return the exterior ring (world [m]) of vehicle-frame `poly` as a simple polygon, or None if degenerate.

    Simplifying and rounding may leave a sliver with zero area or a ring that touches itself; such a
    ring is repaired (largest valid part) once, and given up on (None) if it still is not a simple
    polygon of at least `min_area` [m²].
    """
    if poly is None or poly.is_empty:
        return None
    part = _largest_part(poly if poly.is_valid else shapely.make_valid(poly))
    if part is None:
        return None
    ring = _ring(part, pose)
    if _simple_ring(ring, min_area):
        return ring
    fixed = _largest_part(shapely.make_valid(ShapelyPolygon(ring)).buffer(0))
    if fixed is None:
        return None
    ring = tuple((round(x, 4), round(y, 4)) for x, y in np.asarray(fixed.exterior.coords)[:-1].tolist())
    return ring if _simple_ring(ring, min_area) else None


def position_fix(cal: CalibrationResult | None) -> PointFix | LineFix | None:
    """Return the vocabulary fix (point with covariance, or line) of a calibration."""
    if cal is None:
        return None
    cov = np.asarray(cal.covariance, dtype=np.float64) + COV_FLOOR
    cov = 0.5 * (cov + cov.T)
    if cal.kind == "point":
        flat = tuple(float(v) for v in cov.reshape(-1))
        flat = tuple(0.5 * (flat[3 * i + j] + flat[3 * j + i]) for i in range(3) for j in range(3))
        return PointFix(pose=Pose.from_pose2d(cal.pose), covariance=flat)
    lateral = float(cal.lateral_var + LINE_COV_FLOOR[0, 0])
    if cal.yaw_known:
        yaw_var = float(np.asarray(cal.covariance, dtype=np.float64)[2, 2] + LINE_COV_FLOOR[2, 2])
        return LineFix(point=(cal.pose[0], cal.pose[1]), direction=cal.line_direction, lateral_var=lateral,
                       yaw=cal.pose[2], yaw_var=yaw_var)
    return LineFix(point=(cal.pose[0], cal.pose[1]), direction=cal.line_direction, lateral_var=lateral)


def build_result(
    unit: DrivingUnitDescription,
    out: PipelineOutput,
    prior: tuple[float, float, float],
    captured_at: float,
    img: ColoredRangeImage | None = None,
    processing_s: float | None = None,
) -> PerceptionResult:
    """Return the PerceptionResult of one cycle for `unit` (world frame)."""
    pose = best_pose(out.calibration, prior)
    detected = []
    ids = out.segmented.patches.ids
    work_rgb = img.subsample(out.plan.step).rgb if img is not None else None
    of_found = np.zeros(int(ids.max()) + 1 if ids.size else 1, dtype=bool)  # patch id → one of this object's patches
    for f in out.found:
        colour = None
        if work_rgb is not None:
            pids = [p.id for p in f.patches]
            of_found[pids] = True
            m = of_found[ids]
            of_found[pids] = False
            if m.any():
                colour = tuple(float(np.clip(v, 0, 255)) for v in column_mean(work_rgb[m]))
        surfaces = [p.surface for p in f.patches if p.surface is not None]
        surface = "unknown"
        if surfaces:
            main = max(set(surfaces), key=surfaces.count)
            surface = _SURFACE.get(ST(main), "unknown")
            if f.predicted.obj.kind == "stairs" and main == ST.ROUGH:
                surface = "stairs"
        normals = [p.normal for p in f.patches if p.normal is not None]
        normal = None
        if normals:
            n = np.mean(np.asarray(normals), axis=0)
            n = n / max(float(np.linalg.norm(n)), 1e-9)
            normal = (float(n[0]), float(n[1]), float(n[2]))
        outline = world_ring(f.outline.simplify(0.05), pose, min_area=0.0)
        if outline is None:
            continue
        detected.append(DetectedObject(
            object_id=f.predicted.obj.object_id, kind=f.predicted.obj.kind, outline=outline,
            surface=surface, colour_mean=colour, normal=normal, confidence=float(np.clip(f.score, 0.0, 1.0)),
        ))
    nav = None
    failure = out.failure
    if out.navigable is not None:
        nav = world_ring(out.navigable.simplify(0.05), pose)
        if nav is None and not failure:
            # The path objects were found, but what is left of them is no passage (a sliver, a ring
            # that touches itself): the unit fails with that reason instead of reporting it.
            failure = f"navigable region degenerate (area {out.navigable.area:.3f} m², valid {out.navigable.is_valid})"
    status = "failed" if failure else "perceived"
    vf = world_ring(ShapelyPolygon(out.plan.view_frame), pose, min_area=0.0) if out.plan.distance > out.plan.near else None
    return PerceptionResult(
        unit_id=unit.unit_id,
        segment_id=unit.segment_id,
        status=status,
        failure_reason=failure,
        captured_at=float(captured_at),
        sensor=SENSOR_MODE[out.method],
        frame="world",
        view_frame=vf,
        detected=tuple(detected),
        navigable_region=nav,
        fix=position_fix(out.calibration) if not failure else None,
        processing_s=float(out.seconds if processing_s is None else processing_s),
    )


def failed_result(unit: DrivingUnitDescription, reason: str, captured_at: float, sensor: str = "colored-range") -> PerceptionResult:
    """Return a failed PerceptionResult that says why (no image, no pose, …)."""
    return PerceptionResult(unit_id=unit.unit_id, segment_id=unit.segment_id, status="failed", failure_reason=reason,
                            captured_at=float(captured_at), sensor=sensor)  # type: ignore[arg-type]
