"""Score the laser libraries against truth: obstacle precision/recall, landmark position error, time per frame.

Truth obstacles are the world's standing objects (buildings, trees, posts, mailboxes, …) and the
actors, taller than 0.3 m, whose footprint lies within 15 m of the vehicle and that the scanner
actually hit (at least `min_hits` true returns within 0.3 m of the footprint). A detection (a
polygon from `modules.perception.obstacles`, put in the `world` frame at the true pose) within 15 m
is correct when it lies within 0.5 m of any standing object or actor. `ObstacleCounts` is that
definition for any sensor (its own true surface points decide what it saw; FIDO's and dense
stereo's evaluation use it too). Landmark error: each landmark
observation against the nearest round standing object (tree, post, mailbox, …) within 1.5 m.
This module reads truth; it is evaluation only.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

from modules.perception.landmarks import landmark_observations
from modules.perception.obstacles import LaserScan, detect_obstacles
from wire.summary import percentile

__all__ = ["ObstacleCounts", "LaserEvaluation", "truth_obstacles", "score_frame", "laser_truth_points", "world_of", "BANDS"]

#: Distance bands [m] for the per-band figures.
BANDS: tuple[tuple[float, float], ...] = ((0.0, 5.0), (5.0, 10.0), (10.0, 15.0))


def truth_obstacles(world, actors, t: float) -> list[tuple[str, "shapely.Geometry", bool]]:
    """Return (id, footprint, round) of every standing object taller than 0.3 m and every present actor at sim time t [s]."""
    from vehicle_sim.worldfile import PostShape, PrismShape, TreeShape

    out = []
    for o in world.objects:
        s = o.shape
        if isinstance(s, (PrismShape, TreeShape, PostShape)) and s.height > 0.3:
            out.append((o.id, o.footprint, o.center is not None))
    if actors is not None:
        for a, corners in actors.footprints(t):
            if a.box[2] > 0.3:
                out.append((a.id, Polygon(corners), False))
    return out


def _ratio(a: float, b: float) -> float:
    return float(a / b) if b else float("nan")


@dataclass
class ObstacleCounts:
    """One sensor's obstacle detections counted over frames by the definition above."""

    max_distance: float = 15.0
    min_hits: int = 5
    tp: int = 0
    fp: int = 0
    found: int = 0
    visible: int = 0
    band_tp: list = field(default_factory=lambda: [0] * len(BANDS))
    band_fp: list = field(default_factory=lambda: [0] * len(BANDS))
    band_found: list = field(default_factory=lambda: [0] * len(BANDS))
    band_visible: list = field(default_factory=lambda: [0] * len(BANDS))

    def obstacle_dict(self) -> dict:
        """Return the obstacle figures as a JSON-ready dict (NaN where a ratio has nothing to count)."""
        bands = {}
        for k, (lo, hi) in enumerate(BANDS):
            bands[f"{lo:g}-{hi:g}m"] = {"precision": _ratio(self.band_tp[k], self.band_tp[k] + self.band_fp[k]),
                                        "recall": _ratio(self.band_found[k], self.band_visible[k]),
                                        "detections": self.band_tp[k] + self.band_fp[k], "visible": self.band_visible[k]}
        return {
            "obstacle_precision": _ratio(self.tp, self.tp + self.fp),
            "obstacle_recall": _ratio(self.found, self.visible),
            "obstacle_detections": self.tp + self.fp,
            "obstacle_visible": self.visible,
            "by_distance": bands,
        }

    def score(self, truth: list, pose: tuple[float, float, float], seen: np.ndarray,
              detections: Sequence[tuple["shapely.Geometry", float]], also_seen: np.ndarray | None = None) -> None:
        """Count one frame: `seen` (N, 2) the sensor's true surface points above 0.3 m (`world` x, y [m]); `detections`
        (geometry in `world`, distance from the vehicle [m]); the vehicle at the true `world` pose (x, y [m], yaw [rad]).
        With `also_seen` (M, 2), another sensor's points, only obstacles both sensors saw count as visible."""
        here = Point(pose[0], pose[1])
        trees = [shapely.STRtree(shapely.points(p)) if len(p) else None for p in ((seen,) if also_seen is None else (seen, also_seen))]
        foot = [g for _, g, _ in truth]
        for tid, g, _ in truth:
            dist = g.distance(here)
            if dist > self.max_distance or any(t is None for t in trees):
                continue
            if any(len(t.query(g, predicate="dwithin", distance=0.3)) < self.min_hits for t in trees):
                continue
            b = _band(dist)
            self.visible += 1
            if b is not None:
                self.band_visible[b] += 1
            if any(d.buffer(0.5).intersects(g) for d, _ in detections):
                self.found += 1
                if b is not None:
                    self.band_found[b] += 1
        for d, distance in detections:
            if distance > self.max_distance:
                continue
            good = any(d.buffer(0.5).intersects(g) for g in foot)
            b = _band(distance)
            if good:
                self.tp += 1
            else:
                self.fp += 1
            if b is not None:
                if good:
                    self.band_tp[b] += 1
                else:
                    self.band_fp[b] += 1


@dataclass
class LaserEvaluation(ObstacleCounts):
    """Accumulated counts and samples over frames."""

    landmark_err: list = field(default_factory=list)
    ms: list = field(default_factory=list)
    frames: int = 0

    def as_dict(self) -> dict:
        """Return the figures as a JSON-ready dict."""
        le = np.asarray(self.landmark_err)
        ms = np.asarray(self.ms)
        return {
            "frames": self.frames,
            **self.obstacle_dict(),
            "landmark_observations": int(len(le)),
            "landmark_error_m_p50": percentile(le, 50, empty=math.nan),
            "landmark_error_m_p95": percentile(le, 95, empty=math.nan),
            "laser_ms_p50": percentile(ms, 50, empty=math.nan),
            "laser_ms_p95": percentile(ms, 95, empty=math.nan),
        }


def _band(d: float) -> int | None:
    for k, (lo, hi) in enumerate(BANDS):
        if lo <= d < hi:
            return k
    return None


def world_of(pose: tuple[float, float, float], p: np.ndarray) -> np.ndarray:
    """Return `vehicle` x-y points (..., 2) [m] in `world` for the vehicle at `pose` (x, y [m], yaw [rad])."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    R = np.array([[c, -s], [s, c]])
    return np.asarray(p) @ R.T + (pose[0], pose[1])


def laser_truth_points(capture) -> np.ndarray:
    """Return the scanner's true returns within 40 m standing above 0.3 m, (N, 3) float64 in `vehicle` [m]."""
    az, el = capture.laser_az.astype(np.float64), capture.laser_el.astype(np.float64)
    ce = np.cos(el)[:, None]
    d = np.stack([ce * np.cos(az)[None], ce * np.sin(az)[None], np.broadcast_to(np.sin(el)[:, None], ce.shape[:1] + az.shape)], -1)
    T = capture.T_vehicle_laser
    rt = capture.laser_range_true.astype(np.float64)
    ok = np.isfinite(rt) & (rt <= 40.0)
    pv = (d @ T[:3, :3].T) * np.where(ok, rt, 0.0)[..., None] + T[:3, 3]
    return pv[ok & (pv[..., 2] > 0.3)]


def score_frame(ev: LaserEvaluation, capture, truth: list, pose: tuple[float, float, float]) -> None:
    """Score one capture (with truth) taken at the true `world` pose (x, y [m], yaw [rad])."""
    scan = LaserScan.from_capture(capture)
    t0 = time.perf_counter()
    obs = detect_obstacles(scan)
    lms = landmark_observations(obs)
    ev.ms.append(1e3 * (time.perf_counter() - t0))
    ev.frames += 1
    # true returns in the world frame (evaluation may read the true range)
    seen = world_of(pose, laser_truth_points(capture)[:, :2])
    ev.score(truth, pose, seen, [(Polygon(world_of(pose, o.polygon)), o.distance) for o in obs if len(o.polygon) >= 3])
    rounds = [(g.centroid.x, g.centroid.y) for _, g, r in truth if r]
    if rounds:
        C = np.asarray(rounds)
        for lm in lms:
            w = world_of(pose, [lm.x, lm.y])
            dd = np.linalg.norm(C - w, axis=1)
            if dd.min() <= 1.5:
                ev.landmark_err.append(float(dd.min()))
