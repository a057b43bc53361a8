"""Landmarks from range data: discrete objects (trees, posts, mailboxes) with a sensor-model covariance, matched to a map.

Obstacles small enough to be a post, a trunk or a mailbox become landmark observations: a position
in the `vehicle` frame with a covariance that grows with distance (range noise along the ray,
angular resolution across it, seed Navlab 1990 §1.2.4). `match_landmarks` puts them in the `world`
frame at the predicted vehicle pose and pairs each with the nearest map landmark inside a
Mahalanobis gate; `landmark_fix` turns the pairs into a vehicle position fix (mean and covariance).
Pure numpy; no blackboard, no truth.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.perception.obstacles import Obstacle

__all__ = [
    "LandmarkConfig",
    "LandmarkObservation",
    "MapLandmark",
    "LandmarkMatch",
    "PositionFix",
    "landmark_observations",
    "observation_covariance",
    "match_landmarks",
    "landmark_fix",
    "LANDMARK_KINDS",
    "map_landmarks",
]

#: Kinds of map objects that are discrete landmarks the laser finds (round footprints: a centre and a radius).
LANDMARK_KINDS = ("tree", "mailbox", "sign", "hydrant", "lamp_post", "post", "bench", "rock")


class LandmarkConfig(BaseModel):
    """Which obstacles are landmarks, the sensor model and the gate."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    max_size: float = Field(1.6, gt=0.0)  # largest extent of a discrete landmark [m]
    min_height: float = Field(0.5, gt=0.0)  # [m]
    max_range: float = Field(18.0, gt=0.0)  # [m]
    sigma_range0: float = Field(0.10, gt=0.0)  # along-ray σ at 0 m [m]
    sigma_range_k: float = Field(0.012, ge=0.0)  # along-ray σ growth [m per m]
    sigma_bearing: float = Field(0.012, gt=0.0)  # across-ray σ [rad] (a few laser columns)
    gate: float = Field(3.0, gt=0.0)  # Mahalanobis gate [σ]


class LandmarkObservation(BaseModel):
    """A discrete object seen in one scan: `vehicle`-frame position (x, y) [m], covariance (2×2) [m²], size and height [m]."""

    model_config = ConfigDict(frozen=True)

    x: float
    y: float
    cov: tuple[tuple[float, float], tuple[float, float]]
    size: float
    height: float


class MapLandmark(BaseModel):
    """A landmark of the map: id, `world` position (x, y) [m] and its uncertainty σ [m]."""

    model_config = ConfigDict(frozen=True)

    id: str
    x: float
    y: float
    sigma: float = 0.2


class LandmarkMatch(BaseModel):
    """An observation paired with a map landmark: `world` position observed (x, y) [m], Mahalanobis distance [σ]."""

    model_config = ConfigDict(frozen=True)

    landmark_id: str
    observed: tuple[float, float]
    mapped: tuple[float, float]
    cov: tuple[tuple[float, float], tuple[float, float]]
    mahalanobis: float


class PositionFix(BaseModel):
    """A vehicle position correction in the `world` frame: dx, dy [m] to add to the predicted pose, covariance [m²]."""

    model_config = ConfigDict(frozen=True)

    dx: float
    dy: float
    cov: tuple[tuple[float, float], tuple[float, float]]
    matches: int


def observation_covariance(x: float, y: float, cfg: LandmarkConfig = LandmarkConfig()) -> np.ndarray:
    """Return the (2, 2) covariance [m²] of a point seen at (x, y) [m] (`vehicle` frame): grows with distance."""
    r = math.hypot(x, y)
    b = math.atan2(y, x)
    sr = cfg.sigma_range0 + cfg.sigma_range_k * r
    sb = max(cfg.sigma_bearing * r, 0.05)
    R = np.array([[math.cos(b), -math.sin(b)], [math.sin(b), math.cos(b)]])
    return R @ np.diag([sr * sr, sb * sb]) @ R.T


def landmark_observations(obstacles: list[Obstacle], cfg: LandmarkConfig = LandmarkConfig()) -> list[LandmarkObservation]:
    """Return the obstacles that are discrete landmarks (small, tall enough, near enough) as observations."""
    out = []
    for o in obstacles:
        x, y = o.centroid
        if o.size <= cfg.max_size and o.height >= cfg.min_height and math.hypot(x, y) <= cfg.max_range:
            c = observation_covariance(x, y, cfg)
            out.append(LandmarkObservation(x=x, y=y, cov=((c[0, 0], c[0, 1]), (c[1, 0], c[1, 1])), size=o.size, height=o.height))
    return out


def _to_world(pose: tuple[float, float, float], x: float, y: float, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    R = np.array([[c, -s], [s, c]])
    return np.array([pose[0], pose[1]]) + R @ np.array([x, y]), R @ cov @ R.T


def match_landmarks(observations: list[LandmarkObservation], landmarks: list[MapLandmark], pose: tuple[float, float, float],
                    pose_cov: np.ndarray | None = None, cfg: LandmarkConfig = LandmarkConfig()) -> list[LandmarkMatch]:
    """Pair observations with map landmarks at the predicted `world` pose (x, y [m], yaw [rad]) inside the gate.

    The gate uses the observation covariance plus the landmark's and the pose's position covariance
    (2×2 [m²]); each map landmark is used at most once (nearest pairs first).
    """
    if not observations or not landmarks:
        return []
    P = np.zeros((2, 2)) if pose_cov is None else np.asarray(pose_cov, float)
    L = np.array([[m.x, m.y] for m in landmarks])
    cands = []
    for k, o in enumerate(observations):
        w, cw = _to_world(pose, o.x, o.y, np.asarray(o.cov))
        for j, m in enumerate(landmarks):
            d = w - L[j]
            S = cw + P + np.eye(2) * m.sigma ** 2
            md = float(math.sqrt(d @ np.linalg.solve(S, d)))
            if md <= cfg.gate:
                cands.append((md, k, j, w, cw))
    cands.sort(key=lambda c: c[0])
    used_o, used_l, out = set(), set(), []
    for md, k, j, w, cw in cands:
        if k in used_o or j in used_l:
            continue
        used_o.add(k)
        used_l.add(j)
        m = landmarks[j]
        out.append(LandmarkMatch(landmark_id=m.id, observed=(float(w[0]), float(w[1])), mapped=(m.x, m.y),
                                 cov=((cw[0, 0] + m.sigma ** 2, cw[0, 1]), (cw[1, 0], cw[1, 1] + m.sigma ** 2)), mahalanobis=md))
    return out


def landmark_fix(matches: list[LandmarkMatch]) -> PositionFix | None:
    """Return the information-weighted position correction [m] the matches agree on (None without matches)."""
    if not matches:
        return None
    info = np.zeros((2, 2))
    vec = np.zeros(2)
    for m in matches:
        Wi = np.linalg.inv(np.asarray(m.cov))
        info += Wi
        vec += Wi @ (np.asarray(m.mapped) - np.asarray(m.observed))
    cov = np.linalg.inv(info)
    d = cov @ vec
    return PositionFix(dx=float(d[0]), dy=float(d[1]), cov=((cov[0, 0], cov[0, 1]), (cov[1, 0], cov[1, 1])), matches=len(matches))


def map_landmarks(objects, sigma: float = 0.2) -> list[MapLandmark]:
    """Return the map's discrete landmarks: objects (`wire.mapfile.WorldObject`) of a landmark kind with a centre [m], `world`."""
    return [MapLandmark(id=o.id, x=float(o.center[0]), y=float(o.center[1]), sigma=sigma)
            for o in objects if o.kind in LANDMARK_KINDS and o.center is not None]
