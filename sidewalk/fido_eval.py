"""Score FIDO against truth, beside today's dense stereo (OpenCV StereoSGBM) and the laser, on the same steps.

The vehicle is put at true poses along legs of 1 m steps (straight pieces of the shipped missions'
routes, approaches to the evaluation's actors, and one straight leg for the motion finding); at each
step the simulator captures the laser and the stereo pair with truth, and
- FIDO (`modules.fido`) runs one step, its search guided by simulated wheel odometry (the
  simulator's drift model) as FIDO's was by dead reckoning;
- SGBM (`modules.dense_stereo`) computes the left image's disparity; its points go through the
  laser's height-map obstacle detector, and Lucas–Kanade tracks with SGBM depth give its motion;
- the laser's obstacle detector runs on the scan.

Figures: feature depth error against the true depth of the left pixel (p50/p95 per band of true
depth; pixels whose truth straddles a depth edge or is sky are counted apart); obstacle precision,
recall and false-positive rate by the laser evaluation's definition (`sidewalk.laser_eval`: each
sensor judged on the truth obstacles its own true surface points show; FIDO's detections are its
obstacle features, points); the motion estimate's error per metre against the true motion (each
leg's end-point error over the distance driven, and per step); time per step, wall and CPU (the
process's: the machine may be shared, and OpenCV runs SGBM on several threads). FIDO's obstacle
features are also counted by the true class of the surface under them, and the false detections of
SGBM's and the laser's detector by the world's class at their centroid; FIDO's features on the ground
(all, and the false obstacles) by whether they touch fallen leaves (the pixels that change when the
same image is rendered without leaves) or lie within 0.3 m of a shadow's edge (clutter), beside the same
shares for the ground's pixels on an 8-pixel grid (what chance would give). A step whose motion
FIDO (or the baseline) cannot estimate is counted, and the odometry's increment stands in for it.
This module reads truth; it is evaluation only. No NaN leaves it: empty figures are None.
"""

from __future__ import annotations

import copy
import math
import time
from collections import Counter
from dataclasses import dataclass, field

import cv2
import numpy as np
from shapely.geometry import Point, Polygon

from modules.dense_stereo import disparity_depth, disparity_points, lk_step, sgbm_disparity
from modules.fido import FidoConfig, PlanarMotion, StereoPair, StereoRig, fido_step
from modules.perception.obstacles import LaserScan, detect_obstacles, obstacles_from_points
from sidewalk.laser_eval import ObstacleCounts, laser_truth_points, truth_obstacles, world_of
from wire.summary import percentile

__all__ = ["DEPTH_BANDS", "GROUND_KINDS", "Leg", "DepthErrors", "MotionLeg", "ClutterCounts", "FidoEvaluation", "straight_leg", "segment_leg",
           "approach_leg", "relative_motion", "stereo_truth_points", "ground_grid", "json_ready"]

#: Surfaces of the ground (the rest are standing objects, or sky at a silhouette).
GROUND_KINDS = ("grass", "road", "driveway", "sidewalk", "intersection", "slope", "stairs")

#: Bands of true depth [m] for the depth-error figures.
DEPTH_BANDS: tuple[tuple[float, float], ...] = ((0.0, 5.0), (5.0, 10.0), (10.0, 20.0), (20.0, 40.0))


def json_ready(obj):
    """Return `obj` with every non-finite float replaced by None (and numpy scalars by Python ones)."""
    if isinstance(obj, dict):
        return {k: json_ready(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_ready(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(float(obj)) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def _pct(values, q: float) -> float | None:
    return percentile(np.asarray(values, np.float64), q)


# ---- legs -----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Leg:
    """True poses (K, 3) `world` (x, y [m], yaw [rad]) one step apart, their sim times (K,) [s], and what the leg is."""

    poses: np.ndarray
    stamps: np.ndarray
    kind: str


def _poses_along(a: np.ndarray, b: np.ndarray, s0: float, steps: int, step: float, lateral: float,
                 yaw_sigma: float, rng: np.random.Generator) -> np.ndarray:
    d = (b - a) / np.linalg.norm(b - a)
    yaw = math.atan2(d[1], d[0])
    left = np.array([-d[1], d[0]])
    s = s0 + step * np.arange(steps + 1)
    xy = a + s[:, None] * d + lateral * left
    yaws = yaw + rng.normal(0.0, yaw_sigma, len(s))
    return np.column_stack([xy, yaws])


def straight_leg(segments: list[tuple[np.ndarray, np.ndarray]], length: float, step: float, t0: float, dt: float,
                 rng: np.random.Generator, yaw_sigma: float = math.radians(1.0)) -> Leg | None:
    """Return a leg of `length` [m] along the first segment long enough (1 m in, keeping 0.75 m right), None if none is."""
    for a, b in segments:
        if np.linalg.norm(b - a) >= length + 2.0:
            steps = int(round(length / step))
            poses = _poses_along(a, b, 1.0, steps, step, -0.75, yaw_sigma, rng)
            return Leg(poses, t0 + dt * np.arange(len(poses)), "straight")
    return None


def segment_leg(segments: list[tuple[np.ndarray, np.ndarray]], steps: int, step: float, t0: float, dt: float,
                rng: np.random.Generator, yaw_sigma: float = math.radians(1.0)) -> Leg:
    """Return a leg of up to `steps` steps from a random place on a random segment (weighted by length), a random lateral offset."""
    lengths = np.array([np.linalg.norm(b - a) for a, b in segments])
    i = int(rng.choice(len(segments), p=lengths / lengths.sum()))
    a, b = segments[i]
    n = max(1, min(steps, int((lengths[i] - 1.0) // step)))
    s0 = rng.uniform(0.0, max(lengths[i] - n * step, 0.0))
    poses = _poses_along(a, b, s0, n, step, rng.uniform(-0.4, 0.4), yaw_sigma, rng)
    return Leg(poses, t0 + dt * np.arange(len(poses)), "route")


def approach_leg(segments: list[tuple[np.ndarray, np.ndarray]], target: tuple[float, float], steps: int, step: float,
                 t0: float, dt: float, rng: np.random.Generator, start: float = 15.0, stop: float = 3.0,
                 yaw_sigma: float = math.radians(1.0)) -> Leg:
    """Return a leg of at most `steps` steps towards `target` (x, y) [m] along the segment nearest it, ending `stop` [m]
    before it and starting no farther than `start` [m]; a random lateral offset of up to 1 m from the target's line."""
    t = np.asarray(target, np.float64)

    def dist(seg):
        a, b = seg
        e = b - a
        u = np.clip(np.dot(t - a, e) / np.dot(e, e), 0.0, 1.0)
        return float(np.linalg.norm(a + u * e - t))

    a, b = min(segments, key=dist)
    d = (b - a) / np.linalg.norm(b - a)
    along = float(np.dot(t - a, d))
    lateral = float(np.clip(-d[1] * (t[0] - a[0]) + d[0] * (t[1] - a[1]) + rng.uniform(-1.0, 1.0), -1.0, 1.0))
    n = max(1, min(steps, int((start - stop) // step)))
    poses = _poses_along(a, b, along - stop - n * step, n, step, lateral, yaw_sigma, rng)
    return Leg(poses, t0 + dt * np.arange(len(poses)), "actor")


def relative_motion(p0: np.ndarray, p1: np.ndarray) -> PlanarMotion:
    """Return the motion `previous ← current` between two `world` poses (x, y [m], yaw [rad])."""
    c, s = math.cos(p0[2]), math.sin(p0[2])
    dx, dy = p1[0] - p0[0], p1[1] - p0[1]
    return PlanarMotion(c * dx + s * dy, -s * dx + c * dy, math.remainder(p1[2] - p0[2], math.tau))


def _compose(pose: np.ndarray, m: PlanarMotion) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + c * m.dx - s * m.dy, pose[1] + s * m.dx + c * m.dy, pose[2] + m.dyaw])


# ---- figures --------------------------------------------------------------------------------------------------


@dataclass
class DepthErrors:
    """Absolute depth errors [m] per band of true depth; points whose truth is a depth edge or sky counted apart."""

    errors: list = field(default_factory=lambda: [[] for _ in DEPTH_BANDS])
    no_truth: int = 0
    beyond: int = 0

    def add(self, estimate: np.ndarray, truth: np.ndarray) -> None:
        """Add estimated and true depths (N,) [m] (truth NaN = edge, inf = sky)."""
        est, tru = np.asarray(estimate, np.float64), np.asarray(truth, np.float64)
        known = np.isfinite(tru)
        self.no_truth += int((~known).sum())
        err = np.abs(est - tru)
        placed = np.zeros(len(tru), bool)
        for k, (lo, hi) in enumerate(DEPTH_BANDS):
            sel = known & (tru >= lo) & (tru < hi)
            self.errors[k].extend(err[sel].tolist())
            placed |= sel
        self.beyond += int((known & ~placed).sum())

    def as_dict(self) -> dict:
        """Return p50/p95 [m] and counts per band."""
        out = {f"{lo:g}-{hi:g}m": {"p50": _pct(e, 50), "p95": _pct(e, 95), "n": len(e)}
               for (lo, hi), e in zip(DEPTH_BANDS, self.errors)}
        out.update(no_truth=self.no_truth, beyond=self.beyond)
        return out


@dataclass
class MotionLeg:
    """One leg's motion estimates integrated against the truth: the estimate, or the odometry where it failed."""

    true: list = field(default_factory=list)
    est: list = field(default_factory=list)
    step_err: list = field(default_factory=list)  # [m] per step, translation
    yaw_err: list = field(default_factory=list)  # [rad] per step
    failures: int = 0

    def add(self, pose_true: np.ndarray, truth: PlanarMotion | None, estimate: PlanarMotion | None,
            odometry: PlanarMotion | None) -> None:
        """Add a step: the true pose, the true motion since the last step, the estimate (None: failed) and the odometry."""
        if not self.true:
            self.true.append(np.asarray(pose_true, np.float64))
            self.est.append(np.asarray(pose_true, np.float64))
            return
        assert truth is not None and odometry is not None
        if estimate is None:
            self.failures += 1
            used = odometry
        else:
            used = estimate
            self.step_err.append(math.hypot(estimate.dx - truth.dx, estimate.dy - truth.dy))
            self.yaw_err.append(abs(math.remainder(estimate.dyaw - truth.dyaw, math.tau)))
        self.true.append(np.asarray(pose_true, np.float64))
        self.est.append(_compose(self.est[-1], used))

    @property
    def distance(self) -> float:
        """Return the true distance driven [m]."""
        t = np.asarray(self.true)
        return float(np.sum(np.linalg.norm(np.diff(t[:, :2], axis=0), axis=1))) if len(t) > 1 else 0.0

    @property
    def end_error(self) -> float:
        """Return the end point's position error [m]."""
        return float(np.linalg.norm(self.est[-1][:2] - self.true[-1][:2])) if self.true else 0.0

    def as_dict(self) -> dict:
        """Return the leg's distance, end error, end error per metre, distance estimate, and failures."""
        est = np.asarray(self.est)
        d_est = float(np.sum(np.linalg.norm(np.diff(est[:, :2], axis=0), axis=1))) if len(est) > 1 else 0.0
        dist = self.distance
        return {"distance_m": dist, "end_error_m": self.end_error,
                "end_error_pct": 100.0 * self.end_error / dist if dist else None,
                "distance_estimate_m": d_est, "distance_error_pct": 100.0 * (d_est - dist) / dist if dist else None,
                "heading_error_deg": math.degrees(abs(math.remainder(float(est[-1][2] - self.true[-1][2]), math.tau))) if len(est) else None,
                "failures": self.failures, "steps": max(len(self.true) - 1, 0)}


def _motion_summary(legs: list[MotionLeg]) -> dict:
    per_m = [leg.end_error / leg.distance for leg in legs if leg.distance > 0]
    steps = [e for leg in legs for e in leg.step_err]
    yaws = [math.degrees(e) for leg in legs for e in leg.yaw_err]
    return {"legs": len(legs), "end_error_per_m_p50": _pct(per_m, 50), "end_error_per_m_p95": _pct(per_m, 95),
            "step_error_m_p50": _pct(steps, 50), "step_error_m_p95": _pct(steps, 95),
            "step_yaw_error_deg_p50": _pct(yaws, 50), "step_yaw_error_deg_p95": _pct(yaws, 95),
            "failures": sum(leg.failures for leg in legs), "steps": sum(max(len(leg.true) - 1, 0) for leg in legs)}


@dataclass
class ClutterCounts:
    """Points on the ground within 15 m (FIDO's features, or the chance rate's grid pixels): how many, how many touch
    fallen leaves (a leaf pixel within 2 px in the left image), how many lie within 0.3 m of a shadow's edge."""

    features: int = 0
    on_leaves: int = 0
    at_shadow_edges: int = 0

    def add(self, leaf: np.ndarray, shadow: np.ndarray) -> None:
        """Count points whose flags are `leaf` (N,) bool and `shadow` (N,) bool."""
        leaf, shadow = np.asarray(leaf, bool), np.asarray(shadow, bool)
        self.features += int(leaf.size)
        self.on_leaves += int(leaf.sum())
        self.at_shadow_edges += int(shadow.sum())

    def as_dict(self) -> dict:
        """Return the counts and shares."""
        n = self.features
        return {"features": n, "on_leaves": self.on_leaves, "at_shadow_edges": self.at_shadow_edges,
                "on_leaves_share": self.on_leaves / n if n else None, "at_shadow_edges_share": self.at_shadow_edges / n if n else None}


def stereo_truth_points(capture) -> np.ndarray:
    """Return the left stereo camera's true surface points standing above 0.3 m, (N, 3) float64 `vehicle` [m]."""
    z = capture.stereo_depth_true.astype(np.float64)
    K, T = capture.stereo_K, capture.T_vehicle_stereo_left
    v, u = np.nonzero(np.isfinite(z) & (z <= 40.0))
    zz = z[v, u]
    cam = np.stack([(u - K[0, 2]) * zz / K[0, 0], (v - K[1, 2]) * zz / K[1, 1], zz], 1)
    p = cam @ T[:3, :3].T + T[:3, 3]
    return p[p[:, 2] > 0.3]


def ground_grid(capture, reach: float, step: int = 8) -> np.ndarray:
    """Return the left stereo pixels (N, 2) int (u, v) of a regular `step`-pixel grid that see the ground within `reach` [m]."""
    from vehicle_sim.worldfile import KINDS

    z = capture.stereo_depth_true[step // 2::step, step // 2::step].astype(np.float64)
    label = capture.stereo_labels[step // 2::step, step // 2::step]
    i, j = np.nonzero(np.isin(label, [KINDS.index(k) for k in GROUND_KINDS]) & np.isfinite(z))
    u, v, zz = j * step + step // 2, i * step + step // 2, z[i, j]
    K, T = capture.stereo_K, capture.T_vehicle_stereo_left
    p = np.stack([(u - K[0, 2]) * zz / K[0, 0], (v - K[1, 2]) * zz / K[1, 1], zz], 1) @ T[:3, :3].T + T[:3, 3]
    near = np.hypot(p[:, 0], p[:, 1]) <= reach
    return np.stack([u[near], v[near]], 1)


@dataclass
class _SensorCounts:
    own: ObstacleCounts = field(default_factory=ObstacleCounts)
    both: ObstacleCounts = field(default_factory=ObstacleCounts)  # truth obstacles seen by the laser and the stereo camera

    def score(self, truth, pose, seen, also, detections) -> None:
        self.own.score(truth, pose, seen, detections)
        self.both.score(truth, pose, seen, detections, also_seen=also)

    def as_dict(self, frames: int) -> dict:
        d = self.own.obstacle_dict()
        fp = self.own.fp
        d.update(false_positive_rate=(fp / (fp + self.own.tp)) if fp + self.own.tp else None,
                 false_obstacles_per_step=fp / frames if frames else None,
                 recall_seen_by_both=self.both.obstacle_dict()["obstacle_recall"],
                 visible_to_both=self.both.visible)
        return d


@dataclass
class FidoEvaluation:
    """Everything measured over the legs; `run_leg` adds a leg, `as_dict` gives the figures."""

    scene: object
    world: object
    actors: object | None
    vehicle: str
    config: FidoConfig = FidoConfig()
    fido_depth: DepthErrors = field(default_factory=DepthErrors)
    sgbm_depth: DepthErrors = field(default_factory=DepthErrors)
    fido_obstacles: _SensorCounts = field(default_factory=_SensorCounts)
    sgbm_obstacles: _SensorCounts = field(default_factory=_SensorCounts)
    laser_obstacles: _SensorCounts = field(default_factory=_SensorCounts)
    fido_false_surfaces: Counter = field(default_factory=Counter)
    fido_true_surfaces: Counter = field(default_factory=Counter)
    false_surfaces: dict = field(default_factory=lambda: {"sgbm": Counter(), "laser": Counter()})  # the polygon detectors'
    ground_all: ClutterCounts = field(default_factory=ClutterCounts)
    ground_false: ClutterCounts = field(default_factory=ClutterCounts)
    ground_chance: ClutterCounts = field(default_factory=ClutterCounts)  # the ground's pixels on an 8-px grid
    motion: dict = field(default_factory=lambda: {"fido": [], "sgbm_lk": [], "odometry": []})
    straight: dict | None = None
    ms: dict = field(default_factory=lambda: {k: [] for k in ("fido", "sgbm", "lk", "laser", "capture")})
    cpu_ms: dict = field(default_factory=lambda: {k: [] for k in ("fido", "sgbm", "lk", "laser")})
    fido_parts: dict = field(default_factory=lambda: {k: [] for k in ("pyramid", "track", "stereo", "interest", "motion")})
    features: list = field(default_factory=list)
    tracked: list = field(default_factory=list)
    steps: int = 0

    def run_leg(self, leg: Leg, rng: np.random.Generator) -> None:
        """Drive one leg: capture, run every method at each step, score it; the straight leg's motion is kept apart."""
        from vehicle_sim.odometry import DEFAULT_ODOMETRY, NoiseSource, OdometryState, odometry_step
        from vehicle_sim.sensors import CaptureRequest, capture
        from vehicle_sim.worldfile import KINDS

        req = CaptureRequest(camera=False, stereo=True)
        fido_mem = lk_mem = None
        odo_state = OdometryState()
        noise = NoiseSource(rng)
        legs = {k: MotionLeg() for k in ("fido", "sgbm_lk", "odometry")}
        prev_pose = None
        for pose, stamp in zip(leg.poses, leg.stamps):
            pose = tuple(float(v) for v in pose)
            scene = self.scene.at_time(self.actors, float(stamp)) if self.actors is not None else self.scene
            t0 = time.perf_counter()
            cap = capture(scene, pose, float(stamp), req, vehicle=self.vehicle, rng=rng)
            self.ms["capture"].append(1e3 * (time.perf_counter() - t0))
            truth_motion = odo = None
            if prev_pose is not None:
                truth_motion = relative_motion(np.asarray(prev_pose), np.asarray(pose))
                ds = math.hypot(truth_motion.dx, truth_motion.dy)
                new_state = odometry_step(odo_state, ds, truth_motion.dyaw, 1.0, DEFAULT_ODOMETRY, noise.pair())
                odo = relative_motion(np.array([odo_state.x, odo_state.y, odo_state.yaw]),
                                      np.array([new_state.x, new_state.y, new_state.yaw]))
                odo_state = new_state
            rig, pair = StereoRig.from_capture(cap), StereoPair.from_capture(cap)
            # FIDO
            c0 = time.process_time()
            step = fido_step(pair, rig, fido_mem, self.config, odometry=odo)
            self.cpu_ms["fido"].append(1e3 * (time.process_time() - c0))
            fido_mem = step.memory
            self.ms["fido"].append(step.timing.total_ms)
            for k in self.fido_parts:
                self.fido_parts[k].append(getattr(step.timing, f"{k}_ms"))
            f = step.features
            self.features.append(len(f))
            self.tracked.append(int(f.tracked.sum()))
            ul = np.clip(np.rint(f.uv_left).astype(int), 0, [rig.width - 1, rig.height - 1])
            self.fido_depth.add(f.depth, cap.stereo_depth_true[ul[:, 1], ul[:, 0]])
            # SGBM and Lucas–Kanade on its depth
            t0, c0 = time.perf_counter(), time.process_time()
            disp = sgbm_disparity(pair, rig)
            pts = disparity_points(disp, rig)
            sgbm_obs = obstacles_from_points(pts)
            self.ms["sgbm"].append(1e3 * (time.perf_counter() - t0))
            self.cpu_ms["sgbm"].append(1e3 * (time.process_time() - c0))
            depth = disparity_depth(disp, rig)
            has = np.isfinite(depth)
            self.sgbm_depth.add(depth[has], cap.stereo_depth_true[has])
            t0, c0 = time.perf_counter(), time.process_time()
            lk = lk_step(pair, rig, disp, lk_mem, odo)
            lk_mem = lk.memory
            self.ms["lk"].append(1e3 * (time.perf_counter() - t0))
            self.cpu_ms["lk"].append(1e3 * (time.process_time() - c0))
            # the laser
            t0, c0 = time.perf_counter(), time.process_time()
            laser_obs = detect_obstacles(LaserScan.from_capture(cap))
            self.ms["laser"].append(1e3 * (time.perf_counter() - t0))
            self.cpu_ms["laser"].append(1e3 * (time.process_time() - c0))
            # obstacles, each sensor judged on what its own true surface points show
            truth = truth_obstacles(self.world, self.actors, float(stamp))
            seen_stereo = world_of(pose, stereo_truth_points(cap)[:, :2])
            seen_laser = world_of(pose, laser_truth_points(cap)[:, :2])
            ob = np.nonzero(step.obstacle)[0]
            fido_det = [(Point(*world_of(pose, f.xyz[i, :2])), float(math.hypot(f.xyz[i, 0], f.xyz[i, 1]))) for i in ob]
            self.fido_obstacles.score(truth, pose, seen_stereo, seen_laser, fido_det)
            sgbm_det = [(Polygon(world_of(pose, o.polygon)), o.distance) for o in sgbm_obs if len(o.polygon) >= 3]
            laser_det = [(Polygon(world_of(pose, o.polygon)), o.distance) for o in laser_obs if len(o.polygon) >= 3]
            self.sgbm_obstacles.score(truth, pose, seen_stereo, seen_laser, sgbm_det)
            self.laser_obstacles.score(truth, pose, seen_laser, seen_stereo, laser_det)
            foot = [g for _, g, _ in truth]
            for name, det in (("sgbm", sgbm_det), ("laser", laser_det)):
                self.false_surfaces[name].update(self._false_surfaces(det, foot))
            # clutter: leaves and shadow edges under FIDO's features on the ground, all of them and the false obstacles
            near_leaf = self._near_leaves(scene, pose, float(stamp), rig.width)
            false_ob = {int(i) for (geom, _), i in zip(fido_det, ob) if not any(geom.buffer(0.5).intersects(g) for g in foot)}
            reach = self.fido_obstacles.own.max_distance
            on_ground, is_false = np.zeros(len(f), bool), np.zeros(len(f), bool)
            for i in range(len(f)):
                dist = float(math.hypot(f.xyz[i, 0], f.xyz[i, 1]))
                kind = KINDS[int(cap.stereo_labels[ul[i, 1], ul[i, 0]])]
                if step.obstacle[i] and dist <= reach:
                    (self.fido_false_surfaces if i in false_ob else self.fido_true_surfaces)[kind] += 1
                on_ground[i] = kind in GROUND_KINDS and dist <= reach
                is_false[i] = bool(step.obstacle[i]) and i in false_ob
            g = ul[on_ground]
            leaf, shadow = near_leaf[g[:, 1], g[:, 0]], self._at_shadow_edges(cap, pose, g)
            self.ground_all.add(leaf, shadow)
            self.ground_false.add(leaf[is_false[on_ground]], shadow[is_false[on_ground]])
            grid = ground_grid(cap, reach)
            self.ground_chance.add(near_leaf[grid[:, 1], grid[:, 0]], self._at_shadow_edges(cap, pose, grid))
            # motion
            legs["fido"].add(np.asarray(pose), truth_motion, None if step.motion is None else step.motion.planar, odo)
            legs["sgbm_lk"].add(np.asarray(pose), truth_motion, None if lk.motion is None else lk.motion.planar, odo)
            legs["odometry"].add(np.asarray(pose), truth_motion, odo, odo)
            prev_pose = pose
            self.steps += 1
        if leg.kind == "straight":
            self.straight = {k: v.as_dict() for k, v in legs.items()}
        for k, v in legs.items():
            self.motion[k].append(v)

    def _false_surfaces(self, detections: list, foot: list) -> list[str]:
        """Return the world's class at the centroid of each false detection (geometry in `world`, distance [m]) within reach."""
        from vehicle_sim.worldfile import KINDS

        bad = [d for d, dist in detections if dist <= self.laser_obstacles.own.max_distance
               and not any(d.buffer(0.5).intersects(g) for g in foot)]
        if not bad:
            return []
        xy = np.array([[d.centroid.x, d.centroid.y] for d in bad])
        return [KINDS[int(k)] for k in self.world.label_at(xy)]

    def _near_leaves(self, scene, pose: tuple[float, float, float], stamp: float, size: int) -> np.ndarray:
        """Return (size, size) bool: pixels of the left stereo image with a leaf pixel within 2 px (leaf pixels: those
        that change when the same image is rendered without fallen leaves)."""
        from vehicle_sim.sensors import StereoConfig, stereo_model, stereo_mount_for, world_from_vehicle
        from vehicle_sim.sensors.camera import expose

        if scene.weather is None or scene.weather.leaf_cover <= 0.0:
            return np.zeros((size, size), bool)
        mount = stereo_mount_for(self.vehicle)
        model = stereo_model(StereoConfig(size=size), mount.pitch_deg)
        x, y, yaw = pose
        z = float(scene.elevation(np.array([[x, y]]))[0])
        origin = world_from_vehicle(x, y, yaw, z).apply(mount.vehicle_from_left.t)
        bare = copy.copy(scene)
        bare.weather = scene.weather.model_copy(update={"leaf_cover": 0.0})
        a = expose(scene, origin, yaw, stamp, model).light
        b = expose(bare, origin, yaw, stamp, model).light
        leaf = (np.abs(a - b).max(axis=-1) > 0.5).astype(np.uint8)
        return cv2.dilate(leaf, np.ones((5, 5), np.uint8)).astype(bool)

    def _at_shadow_edges(self, cap, pose: tuple[float, float, float], uv: np.ndarray) -> np.ndarray:
        """Return (N,) bool: whether the true ground point under each left pixel `uv` (N, 2) int lies within 0.3 m of a shadow's edge."""
        z = cap.stereo_depth_true[uv[:, 1], uv[:, 0]].astype(np.float64)
        ok = np.isfinite(z)
        K, T = cap.stereo_K, cap.T_vehicle_stereo_left
        cam = np.stack([(uv[:, 0] - K[0, 2]) * z / K[0, 0], (uv[:, 1] - K[1, 2]) * z / K[1, 1], z], 1)[ok]
        w = world_of(pose, (cam @ T[:3, :3].T + T[:3, 3])[:, :2]).reshape(-1, 2)
        ring = w[:, None, :] + 0.3 * np.array([[0.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
        lit = self.scene.sunlit_at(ring[..., 0], ring[..., 1])
        out = np.zeros(len(uv), bool)
        out[ok] = lit.max(axis=1) - lit.min(axis=1) > 0.5
        return out

    def as_dict(self) -> dict:
        """Return every figure (JSON-ready: None where there was nothing to measure)."""
        def ms(k):
            out = {"p50": _pct(self.ms[k], 50), "p95": _pct(self.ms[k], 95)}
            if k in self.cpu_ms:
                out.update(cpu_p50=_pct(self.cpu_ms[k], 50), cpu_p95=_pct(self.cpu_ms[k], 95))
            return out

        out = {
            "steps": self.steps,
            "features_per_step_p50": _pct(self.features, 50),
            "tracked_per_step_p50": _pct(self.tracked, 50),
            "depth_error_m": {"fido": self.fido_depth.as_dict(), "sgbm": self.sgbm_depth.as_dict()},
            "obstacles": {"fido": self.fido_obstacles.as_dict(self.steps), "sgbm": self.sgbm_obstacles.as_dict(self.steps),
                          "laser": self.laser_obstacles.as_dict(self.steps)},
            "fido_obstacle_surfaces": {"true": dict(self.fido_true_surfaces.most_common()),
                                       "false": dict(self.fido_false_surfaces.most_common()),
                                       "false_on_ground": sum(n for k, n in self.fido_false_surfaces.items() if k in GROUND_KINDS)},
            "false_detection_surfaces": {k: dict(v.most_common()) for k, v in self.false_surfaces.items()},
            "fido_ground_clutter": {"all_features": self.ground_all.as_dict(), "false_obstacles": self.ground_false.as_dict(),
                                    "ground_pixels": self.ground_chance.as_dict()},
            "motion": {k: _motion_summary(v) for k, v in self.motion.items()},
            "straight_leg": self.straight,
            "ms_per_step": {"fido": ms("fido"), "fido_parts_p50": {k: _pct(v, 50) for k, v in self.fido_parts.items()},
                            "sgbm": ms("sgbm"), "lk_on_sgbm": ms("lk"), "laser": ms("laser"), "capture": ms("capture")},
        }
        return json_ready(out)
