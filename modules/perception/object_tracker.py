"""Discrete objects tracked across frames for map building (seed: Navlab 1990 §1.2.4).

Each object found in a range image is matched to the tracked objects using the dead-reckoned
prediction of the vehicle pose (observations arrive in the `world` frame at the predicted pose).
A matched object's position is refined by maximum likelihood (information-weighted mean of every
observation, with its covariance); its confidence rises when it is seen and falls when it is missed
where it should appear (inside the sensor's view and range). Objects whose observations wander
farther than the sensor model allows are moving and are never mapped; objects seen too rarely are
spurious and are dropped. Pure numpy; no blackboard, no truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from wire.se2 import wrap_angle

__all__ = [
    "TrackerConfig",
    "WorldObservation",
    "TrackedObject",
    "ObjectTracker",
    "in_view",
]


class TrackerConfig(BaseModel):
    """Association, confidence and pruning settings."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    associate: float = Field(2.5, gt=0.0)  # association radius [m] (wide: a walker stays one track)
    gate: float = Field(4.0, gt=0.0)  # a static object's observations stay within this Mahalanobis distance [σ]
    moving_distance: float = Field(1.0, gt=0.0)  # observations spread wider than this [m] mark a moving object
    seen: float = Field(0.2, gt=0.0)  # confidence added when seen
    missed: float = Field(0.25, gt=0.0)  # confidence removed when missed where it should appear
    initial: float = Field(0.3, gt=0.0, le=1.0)
    drop_below: float = Field(0.0, ge=0.0)  # tracks at or below this confidence are deleted
    map_confidence: float = Field(0.5, gt=0.0, le=1.0)  # mapped objects need this much confidence
    min_hits: int = Field(3, ge=1)  # and this many sightings
    view_half_angle: float = Field(math.radians(36.0), gt=0.0)  # [rad] (inside the 40° half field)
    view_range: float = Field(14.0, gt=0.0)  # [m]


class WorldObservation(BaseModel):
    """One object seen in one frame, `world` frame: position (x, y) [m], covariance (2×2) [m²], size and height [m]."""

    model_config = ConfigDict(frozen=True)

    x: float
    y: float
    cov: tuple[tuple[float, float], tuple[float, float]]
    size: float = 0.0
    height: float = 0.0


class TrackedObject(BaseModel):
    """A tracked object: `world` mean (x, y) [m], covariance [m²], confidence [0–1], sightings, misses, moving flag."""

    model_config = ConfigDict(frozen=True)

    id: int
    x: float
    y: float
    cov: tuple[tuple[float, float], tuple[float, float]]
    confidence: float
    hits: int
    misses: int
    moving: bool
    size: float
    height: float


@dataclass
class _Track:
    id: int
    info: np.ndarray  # Σ W_i (2, 2)
    vec: np.ndarray  # Σ W_i z_i (2,)
    confidence: float
    first: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    hits: int = 1
    misses: int = 0
    moving: bool = False
    size: float = 0.0
    height: float = 0.0
    seen_now: bool = field(default=False)

    @property
    def mean(self) -> np.ndarray:
        return np.linalg.solve(self.info, self.vec)

    @property
    def cov(self) -> np.ndarray:
        return np.linalg.inv(self.info)


def in_view(pose: tuple[float, float, float], xy: np.ndarray, half_angle: float, max_range: float, min_range: float = 3.0) -> bool:
    """Return True when the `world` point xy [m] lies inside the sensor's view from the vehicle pose (x, y [m], yaw [rad])."""
    dx, dy = float(xy[0]) - pose[0], float(xy[1]) - pose[1]
    r = math.hypot(dx, dy)
    b = wrap_angle(math.atan2(dy, dx) - pose[2])
    return min_range <= r <= max_range and abs(b) <= half_angle


class ObjectTracker:
    """Track discrete objects across frames; `update` once per frame, `mapped()` for the map."""

    def __init__(self, cfg: TrackerConfig = TrackerConfig()) -> None:
        self.cfg = cfg
        self._tracks: list[_Track] = []
        self._next = 1
        self.dropped_spurious = 0
        self.dropped_moving = 0

    def update(self, pose: tuple[float, float, float], observations: list[WorldObservation]) -> None:
        """Fold one frame's observations (`world` frame) in, seen from the predicted vehicle pose (x, y [m], yaw [rad])."""
        cfg = self.cfg
        for t in self._tracks:
            t.seen_now = False
        pairs = []
        for k, o in enumerate(observations):
            z = np.array([o.x, o.y])
            for j, t in enumerate(self._tracks):
                d = float(np.linalg.norm(z - t.mean))
                if d <= cfg.associate:
                    pairs.append((d, k, j))
        pairs.sort()
        used_o: set[int] = set()
        used_t: set[int] = set()
        for d, k, j in pairs:
            if k in used_o or j in used_t:
                continue
            used_o.add(k)
            used_t.add(j)
            self._fold(self._tracks[j], observations[k])
        for k, o in enumerate(observations):
            if k not in used_o:
                W = np.linalg.inv(np.asarray(o.cov))
                z = np.array([o.x, o.y])
                self._tracks.append(_Track(id=self._next, info=W, vec=W @ z, confidence=cfg.initial, first=z, lo=z.copy(), hi=z.copy(),
                                           size=o.size, height=o.height, seen_now=True))
                self._next += 1
        keep = []
        for t in self._tracks:
            if not t.seen_now and in_view(pose, t.mean, cfg.view_half_angle, cfg.view_range):
                t.confidence -= cfg.missed
                t.misses += 1
            if t.confidence <= cfg.drop_below:
                if t.moving:
                    self.dropped_moving += 1
                else:
                    self.dropped_spurious += 1
                continue
            keep.append(t)
        self._tracks = keep

    def _fold(self, t: _Track, o: WorldObservation) -> None:
        cfg = self.cfg
        z = np.array([o.x, o.y])
        W = np.linalg.inv(np.asarray(o.cov))
        d = z - t.mean
        S = t.cov + np.asarray(o.cov)
        if float(math.sqrt(d @ np.linalg.solve(S, d))) > cfg.gate:
            t.moving = True
        t.lo = np.minimum(t.lo, z)
        t.hi = np.maximum(t.hi, z)
        if float(np.linalg.norm(t.hi - t.lo)) > cfg.moving_distance:
            t.moving = True
        if t.moving:  # a moving object's estimate follows it: the newest observation only
            t.info, t.vec = W, W @ z
        else:
            t.info = t.info + W
            t.vec = t.vec + W @ z
        t.confidence = min(1.0, t.confidence + cfg.seen)
        t.hits += 1
        t.size = max(t.size, o.size)
        t.height = max(t.height, o.height)
        t.seen_now = True

    def objects(self) -> list[TrackedObject]:
        """Return every live track."""
        out = []
        for t in self._tracks:
            m, c = t.mean, t.cov
            out.append(TrackedObject(id=t.id, x=float(m[0]), y=float(m[1]), cov=((c[0, 0], c[0, 1]), (c[1, 0], c[1, 1])),
                                     confidence=t.confidence, hits=t.hits, misses=t.misses, moving=t.moving, size=t.size, height=t.height))
        return out

    def mapped(self) -> list[TrackedObject]:
        """Return the objects for the map: confident, seen often enough, never moving."""
        cfg = self.cfg
        return [o for o in self.objects() if o.confidence >= cfg.map_confidence and o.hits >= cfg.min_hits and not o.moving]
