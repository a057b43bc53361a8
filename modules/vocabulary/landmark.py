"""Landmark vocabulary: a vehicle position fix from laser landmarks matched to the map (seed: Navlab 1990 §1.2.4, §2.5.4).

The OBSTACLE DETECTOR finds discrete objects (trees, posts, mailboxes) in each laser scan, puts them
in `world` at the PILOT's perceived position, pairs them with the map's landmarks inside a
Mahalanobis gate and posts the vehicle position they agree on as a `landmark_fix`; the PILOT's
POSITION ESTIMATOR folds it in (behind its own χ² gate) as it does PERCEPTION's fixes.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, Field

from modules.vocabulary._base import XY, Frozen, finite, token_type

__all__ = ["Cov2", "LandmarkFix"]


def _check_cov2(v: tuple[float, ...]) -> tuple[float, ...]:
    if len(v) != 4:
        raise ValueError(f"a 2×2 covariance needs 4 values, got {len(v)}")
    if abs(v[1] - v[2]) > 1e-6 * max(1.0, abs(v[1])) or v[0] <= 0.0 or v[3] <= 0.0 or v[0] * v[3] - v[1] * v[2] <= 0.0:
        raise ValueError("a 2×2 covariance must be symmetric positive definite")
    return v


#: A 2×2 covariance [m²], row-major.
Cov2 = Annotated[tuple[finite, ...], AfterValidator(_check_cov2)]


@token_type("landmark_fix")
class LandmarkFix(Frozen):
    """Where the vehicle was at `sensed_at` [s] sim (`position` (x, y) [m], `world`) by the laser landmarks
    `landmark_ids` matched to the map, with the position's covariance [m²]; `prior` is the perceived
    position the matching started from [m] (`world`)."""

    sensed_at: finite
    position: XY
    covariance: Cov2
    prior: XY
    landmark_ids: tuple[str, ...] = Field(min_length=1)
    frame: Literal["world"] = "world"
