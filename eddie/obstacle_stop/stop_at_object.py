"""Stop at an object: the seed's "stop at objects" trigger, judged against the object the laser sees.

Seed: Navlab 1990 §1.2.3 and §2.5 — the AMV stopped at the mailbox. The believed pose (navigator ∘
controller) can be a metre or two off along the road after a few hundred metres: road edges fix the
across-road error only, and landmarks are sparse. The object itself is in the laser's view as the
vehicle comes up to it (the trigger fires `STOP_LEAD_M` before the goal), so each range image's
discrete objects (`modules.perception.landmarks`) near where the belief predicts the object tell
where the vehicle stands relative to it. The correction — the object's map position less where the
belief puts the object seen — moves the believed position before the distance to the goal is
judged. When the object leaves the view (abeam of the vehicle), the last corrections hold: over the
few metres left, odometry drifts by centimetres.

Frames: `world` for the map, the belief and the corrections; `vehicle` (x forward, y left) for what
the laser sees. Pure numpy; no truth.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.perception.landmarks import LandmarkConfig, landmark_observations
from modules.perception.obstacles import Obstacle

__all__ = ["ObjectSightingConfig", "ObjectSighting", "sight_object", "ObjectCorrection"]


class ObjectSightingConfig(BaseModel):
    """How an object seen by the laser is taken for the map's object."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    #: a discrete object seen this near [m] to where the belief predicts the map's object is taken for it
    gate_m: float = Field(2.5, gt=0.0)
    #: the farthest [m] an object is trusted (range noise and the angular resolution grow with distance)
    max_range_m: float = Field(16.0, gt=0.0)
    #: the largest extent [m] of what is taken for the object (a post with a box on it smears to 1.7 m at 12 m)
    max_size_m: float = Field(2.0, gt=0.0)
    #: how many recent sightings the correction is the median of
    window: int = Field(5, ge=1)
    #: a correction larger than this [m] is refused (another object, not a drifted belief)
    max_correction_m: float = Field(3.0, gt=0.0)


class ObjectSighting(BaseModel):
    """The map's object seen at capture `stamp` [s] sim: `seen_xy` where the belief puts it (`world` [m]), `correction` [m]."""

    model_config = ConfigDict(frozen=True)

    stamp: float
    seen_xy: tuple[float, float]
    correction: tuple[float, float]
    range_m: float


def sight_object(obstacles: list[Obstacle], object_xy: tuple[float, float], pose_world: tuple[float, float, float],
                 stamp: float, cfg: ObjectSightingConfig = ObjectSightingConfig()) -> ObjectSighting | None:
    """Return the sighting of the map object at `object_xy` (`world` [m]) among `obstacles` (`vehicle` frame), or None.

    `pose_world` is the believed pose (x, y [m], yaw [rad]) at the capture. The discrete object
    nearest to where the belief predicts the map's object, within `gate_m`, is taken for it.
    """
    x, y, yaw = pose_world
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = object_xy[0] - x, object_xy[1] - y
    pred = np.array([c * dx + s * dy, -s * dx + c * dy])  # where the map's object should be, `vehicle`
    best = None
    for ob in landmark_observations(obstacles, LandmarkConfig(max_range=cfg.max_range_m, max_size=cfg.max_size_m)):
        d = float(np.hypot(ob.x - pred[0], ob.y - pred[1]))
        if d <= cfg.gate_m and (best is None or d < best[0]):
            best = (d, ob)
    if best is None:
        return None
    ob = best[1]
    seen = (x + c * ob.x - s * ob.y, y + s * ob.x + c * ob.y)
    corr = (object_xy[0] - seen[0], object_xy[1] - seen[1])
    if math.hypot(*corr) > cfg.max_correction_m:
        return None
    return ObjectSighting(stamp=stamp, seen_xy=seen, correction=corr, range_m=float(math.hypot(ob.x, ob.y)))


class ObjectCorrection:
    """The correction [m] (`world`) to the believed position: the median of the last `window` sightings (zero before one)."""

    def __init__(self, cfg: ObjectSightingConfig = ObjectSightingConfig()) -> None:
        self.cfg = cfg
        self.sightings: deque[ObjectSighting] = deque(maxlen=cfg.window)
        self.seen = 0

    def add(self, sighting: ObjectSighting | None) -> None:
        """Take one frame's sighting (None: the object was not seen in it)."""
        if sighting is not None:
            self.sightings.append(sighting)
            self.seen += 1

    @property
    def correction(self) -> tuple[float, float]:
        """Return the correction (dx, dy) [m] `world` to add to the believed position."""
        if not self.sightings:
            return (0.0, 0.0)
        arr = np.array([s.correction for s in self.sightings])
        return (float(np.median(arr[:, 0])), float(np.median(arr[:, 1])))

    def corrected(self, pose_world: tuple[float, float] | np.ndarray) -> tuple[float, float]:
        """Return the believed position (x, y) [m] `world` moved by the correction."""
        cx, cy = self.correction
        return (float(pose_world[0]) + cx, float(pose_world[1]) + cy)
