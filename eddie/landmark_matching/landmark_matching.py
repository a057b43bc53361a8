"""Landmark matching's core: a position fix (`world` ← `vehicle`) from the landmarks the map predicts.

Seed: Navlab 1990 §2.5 — landmark matching runs between triggers "start / stop landmark matching"
and sends position fixes to the navigator. It is PERCEPTION's object finder and position
calibrator (`modules.perception.PerceptionPipeline`) on one frame, given the landmarks the annotated
map lists near the vehicle and the prior pose `world` ← `vehicle` (navigator ∘ controller).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

import math

from eddie.messages.navigator import LineFixMessage, LocalPose, PointFixMessage
from modules.perception import ColoredRangeImage, PerceptionPipeline
from modules.perception.pipeline import PipelineOutput
from modules.vocabulary import MapObject
from wire.se2 import PoseFields

__all__ = ["LandmarkFix", "landmark_fix", "calibration_fix", "fix_message"]


class LandmarkFix(PoseFields, BaseModel):
    """A fix: the vehicle's pose in `world` (x, y [m], yaw [rad]) at capture `stamp` [s] sim, its covariance (3×3, row-major).

    `kind` "point" fixes the position; "line" leaves it free along `line_direction` [rad] (`world`).
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    stamp: float
    x: float
    y: float
    yaw: float
    covariance: tuple[float, ...] = Field(min_length=9, max_length=9)
    kind: str
    line_direction: float = 0.0
    yaw_known: bool = True
    n_used: int = 0


def landmark_fix(pipeline: PerceptionPipeline, img: ColoredRangeImage, landmarks: tuple[MapObject, ...],
                 prior_world: tuple[float, float, float], *, error_allowance_m: float = 0.5) -> tuple[LandmarkFix | None, str]:
    """Return (the fix, "") or (None, why not) for one frame, matching `landmarks` around the prior pose (`world`)."""
    out = pipeline.process(img, landmarks, prior_world, error_allowance=max(error_allowance_m, 0.2))
    fix = calibration_fix(out, float(img.stamp))
    return (fix, "") if fix is not None else (None, out.fix_note or out.failure or "no fix")


def calibration_fix(out: PipelineOutput, stamp: float) -> LandmarkFix | None:
    """Return the position calibration of one PERCEPTION pipeline pass as a fix at capture `stamp` [s] sim (None: none)."""
    cal = out.calibration
    if cal is None:
        return None
    return LandmarkFix.from_pose2d(cal.pose, stamp=stamp,
                                   covariance=tuple(float(v) for v in cal.covariance.reshape(-1)), kind=cal.kind,
                                   line_direction=float(cal.line_direction), yaw_known=bool(cal.yaw_known), n_used=int(cal.n_used))


def fix_message(fix: LandmarkFix, local: tuple[float, float, float], source: str) -> PointFixMessage | LineFixMessage:
    """Return the navigator's fix message for `fix`, with the controller's `local` pose (x, y [m], yaw [rad]) at its capture."""
    at = LocalPose.from_pose2d(local)
    sx = math.sqrt(max(fix.covariance[0], fix.covariance[4], 1e-4))
    syaw = math.sqrt(max(fix.covariance[8], 1e-6))
    if fix.kind == "point":
        return PointFixMessage.from_pose2d(fix.to_pose2d(), stamp=fix.stamp, sigma_xy=sx, sigma_yaw=syaw, local=at, source=source)
    return LineFixMessage(stamp=fix.stamp, x=fix.x, y=fix.y, angle=fix.line_direction, sigma_cross=sx,
                          yaw=fix.yaw if fix.yaw_known else None, sigma_yaw=syaw if fix.yaw_known else None,
                          local=at, source=source)
