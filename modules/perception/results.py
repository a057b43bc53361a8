"""Turn one PERCEPTION cycle into the vocabulary's `PerceptionResult` (world frame) for a driving unit.

Outlines and the navigable region are put into the world frame with the best pose the cycle knows:
the fix when it is a point, the prior moved onto the line when it is a line, else the prior.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import Polygon as ShapelyPolygon

from modules.perception.calibrator import CalibrationResult
from modules.perception.image import ColoredRangeImage
from modules.perception.patch_maker import Segmentation
from modules.perception.pipeline import PipelineOutput
from modules.perception.predicted import vehicle_to_world
from modules.perception.range_seg import SurfaceType as ST
from modules.vocabulary import DetectedObject, DrivingUnitDescription, LineFix, PerceptionResult, PointFix, Pose

__all__ = ["SENSOR_MODE", "best_pose", "position_fix", "build_result", "failed_result"]

#: Vocabulary name of each segmentation module.
SENSOR_MODE = {Segmentation.COLOUR: "colour", Segmentation.RANGE: "range", Segmentation.COLORED_RANGE: "colored-range"}

_SURFACE = {ST.FLAT: "flat", ST.TILTED: "slope", ST.ROUGH: "rough", ST.VERTICAL: "vertical"}

#: Floor added to the calibrator's covariance: map scatter and correlated edge errors ([m²], [m²], [rad²]).
COV_FLOOR = np.diag([0.15**2, 0.15**2, math.radians(0.5) ** 2])


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
    return tuple((round(float(x), 4), round(float(y), 4)) for x, y in w)


def position_fix(cal: CalibrationResult | None) -> PointFix | LineFix | None:
    """Return the vocabulary fix (point with covariance, or line) of a calibration."""
    if cal is None:
        return None
    cov = np.asarray(cal.covariance, dtype=np.float64) + COV_FLOOR
    cov = 0.5 * (cov + cov.T)
    if cal.kind == "point":
        flat = tuple(float(v) for v in cov.reshape(-1))
        flat = tuple(0.5 * (flat[3 * i + j] + flat[3 * j + i]) for i in range(3) for j in range(3))
        return PointFix(pose=Pose(x=cal.pose[0], y=cal.pose[1], yaw=cal.pose[2]), covariance=flat)
    lateral = float(cal.lateral_var + COV_FLOOR[0, 0])
    if cal.yaw_known:
        return LineFix(point=(cal.pose[0], cal.pose[1]), direction=cal.line_direction, lateral_var=lateral,
                       yaw=cal.pose[2], yaw_var=float(cov[2, 2]))
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
    for f in out.found:
        colour = None
        if work_rgb is not None:
            m = np.isin(ids, [p.id for p in f.patches])
            if m.any():
                colour = tuple(float(np.clip(v, 0, 255)) for v in work_rgb[m].mean(axis=0))
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
        outline = f.outline.simplify(0.05)
        if outline.is_empty or outline.geom_type != "Polygon" or len(outline.exterior.coords) < 4:
            continue
        detected.append(DetectedObject(
            object_id=f.predicted.obj.object_id, kind=f.predicted.obj.kind, outline=_ring(outline, pose),
            surface=surface, colour_mean=colour, normal=normal, confidence=float(np.clip(f.score, 0.0, 1.0)),
        ))
    nav = None
    if out.navigable is not None:
        g = out.navigable.simplify(0.05)
        if g.geom_type == "Polygon" and len(g.exterior.coords) >= 4:
            nav = _ring(g, pose)
    status = "failed" if out.failure else "perceived"
    return PerceptionResult(
        unit_id=unit.unit_id,
        segment_id=unit.segment_id,
        status=status,
        failure_reason=out.failure,
        captured_at=float(captured_at),
        sensor=SENSOR_MODE[out.method],
        frame="world",
        view_frame=_ring(ShapelyPolygon(out.plan.view_frame), pose) if out.plan.distance > out.plan.near else None,
        detected=tuple(detected),
        navigable_region=nav,
        fix=position_fix(out.calibration) if not out.failure else None,
        processing_s=float(out.seconds if processing_s is None else processing_s),
    )


def failed_result(unit: DrivingUnitDescription, reason: str, captured_at: float, sensor: str = "colored-range") -> PerceptionResult:
    """Return a failed PerceptionResult that says why (no image, no pose, …)."""
    return PerceptionResult(unit_id=unit.unit_id, segment_id=unit.segment_id, status="failed", failure_reason=reason,
                            captured_at=float(captured_at), sensor=sensor)  # type: ignore[arg-type]
