"""Obstacle stop's core: is something standing on the controller's path, and how far along it?

Seed: Navlab 1990 §2.5 — fast obstacle detection stops the vehicle through the controller (a
trigger starts and stops it). The algorithm is the OBSTACLE DETECTOR's fast mode, as a library
(`modules.perception.obstacles`): the laser points into `vehicle`, unwrapped over the ground, and
only the corridor along the path looked at; a point standing `min_height` above the corridor's
ground is an obstacle point. The path is the one the controller tracks (its `path` stream, in
`local`), moved into `vehicle` by the controller's pose at the capture.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.perception.obstacles import LaserScan, ObstacleConfig, path_clear_distance, path_in_vehicle

__all__ = ["ObstacleStopConfig", "ObstacleReport", "obstacle_ahead", "corridor_path", "stop_verdict", "remaining_m", "braking_m"]


class ObstacleStopConfig(BaseModel):
    """The corridor checked along the path (`vehicle` frame) and the evidence needed."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    # 15 m: at 3 m/s a frame a few seconds old (capture and detection on a loaded machine) plus braking still stops short
    stop_distance_m: float = Field(15.0, gt=0.0, description="stop for an obstacle this near along the path [m]")
    half_width_m: float = Field(1.5, gt=0.0, description="half the swept corridor [m] (the OBSTACLE DETECTOR's)")
    min_points: int = Field(3, ge=1, description="this many obstacle points make an obstacle (noise and mixed points do not)")
    front_m: float = Field(1.1, ge=0.0, description="the body's reach ahead of the vehicle's origin [m] (Terregator 1.1, Navlab 4.6)")
    clearance_m: float = Field(0.5, ge=0.0, description="the front stops at least this short of an obstacle past the path's end [m]")
    decel_mps2: float = Field(1.0, gt=0.0, description="the braking assumed for a stop [m/s²]")
    latency_s: float = Field(0.5, ge=0.0, description="capture to braking [s]: the travel meanwhile counts as braking distance")
    detection: ObstacleConfig = ObstacleConfig()


class ObstacleReport(BaseModel):
    """What one range image shows: `blocked`, the first obstacle point along the path [m] (None: clear)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    blocked: bool
    distance_m: float | None = None
    stamp: float = 0.0


def remaining_m(path_local: np.ndarray, pose_local: tuple[float, float, float]) -> float:
    """Return the length [m] of `path_local` (N, 2) [m, `local`] left ahead of the vehicle at `pose_local`.

    From the vehicle to the path point nearest it, then along the path to its end.
    """
    p = np.asarray(path_local, np.float64).reshape(-1, 2)
    if len(p) == 0:
        return 0.0
    here = np.array(pose_local[:2], np.float64)
    i = int(np.argmin(np.linalg.norm(p - here, axis=1)))
    rest = np.vstack([here, p[i:]])
    return float(np.linalg.norm(np.diff(rest, axis=0), axis=1).sum())


def braking_m(cfg: ObstacleStopConfig, speed: float) -> float:
    """Return how far [m] the vehicle at `speed` [m/s] travels from a capture to standing still (latency, then braking)."""
    v = abs(speed)
    return v * cfg.latency_s + v * v / (2.0 * cfg.decel_mps2)


def obstacle_ahead(scan: LaserScan, cfg: ObstacleStopConfig = ObstacleStopConfig(), *,
                   path_local: np.ndarray | None = None, pose_local: tuple[float, float, float] = (0.0, 0.0, 0.0),
                   speed: float = 0.0) -> ObstacleReport:
    """Return whether to stop now for an obstacle along the path (`blocked`) and how far along it stands.

    `path_local` (N, 2) [m] is the path in `local` and `pose_local` the vehicle's pose there at the
    scan, `speed` [m/s] its speed. An obstacle on the path stops the vehicle once within `stop_distance_m`.
    Without a path the controller is bringing the vehicle to rest where it heads: the corridor runs
    straight ahead, and only an obstacle the front would come within `clearance_m` of while it stops
    (front, clearance and `braking_m`) stops it. Stopping for anything within `stop_distance_m` straight
    ahead instead held a vehicle standing a few degrees askew between two paths for good (the road's edge
    15 m ahead), since the next path is refused while the stop holds. The controller stops at its path's end
    by itself, so an obstacle past the end (a building behind the mission's goal) matters only when
    the front would come within `clearance_m` of it there, and then only once the vehicle is as near
    as its stop needs (front, clearance and `braking_m`): it drives on to the end or to just short of the obstacle.
    Stopping such a vehicle early instead would hold it short of its goal for good, the driving
    module's next path being refused while the stop holds.
    """
    path = corridor_path(cfg, path_local, pose_local)
    d = path_clear_distance(scan, path, cfg.half_width_m, cfg.detection, min_points=cfg.min_points)
    return stop_verdict(d, float(scan.stamp), cfg, path_local=path_local, pose_local=pose_local, speed=speed)


def corridor_path(cfg: ObstacleStopConfig, path_local: np.ndarray | None, pose_local: tuple[float, float, float]) -> np.ndarray:
    """Return the path (K, 2) [m] `vehicle` whose corridor is checked: `path_local` ahead of the vehicle, else straight ahead."""
    return path_in_vehicle(np.empty((0, 2)) if path_local is None else path_local, pose_local, cfg.stop_distance_m)


def stop_verdict(d: float, stamp: float, cfg: ObstacleStopConfig, *, path_local: np.ndarray | None = None,
                 pose_local: tuple[float, float, float] = (0.0, 0.0, 0.0), speed: float = 0.0) -> ObstacleReport:
    """Return the verdict for the first obstacle `d` [m] along the corridor's path (`inf`: clear), sensed at `stamp` [s] sim.

    Any sensor's: the laser's obstacle points (`obstacle_ahead`) or FIDO's obstacle features.
    """
    if not math.isfinite(d):
        return ObstacleReport(blocked=False, distance_m=None, stamp=stamp)
    braking = braking_m(cfg, speed)
    # without a path the vehicle still rolls its braking distance straight ahead: that is its path's end
    left = braking if path_local is None or len(path_local) < 2 else remaining_m(path_local, pose_local)
    if d <= left:
        blocked = d <= cfg.stop_distance_m
    else:
        blocked = d <= min(cfg.stop_distance_m, cfg.front_m + cfg.clearance_m + min(left, braking))
    return ObstacleReport(blocked=blocked, distance_m=float(d), stamp=stamp)
