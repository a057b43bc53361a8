"""Evaluate the road followers (SCARF, YARF, ALVINN) against the true road centre. Pure: frames come in as data.

The composition root (`sidewalk.cli._roadfollow`) drives a vehicle along a route of the world — the
follow-road legs of the world's shipped missions, trimmed clear of intersections — weaving across
its lane, renders the camera at each pose, and hands the frames here with the route's centre line.
Each leg is a run of its own: the follower is made afresh (the seed's bootstrap) at its start.

Errors per frame, in `vehicle`:

* SCARF, YARF — lateral: the reported road-centre offset at x = 0 minus the true one (the route
  centre line crossed with the line x = 0); heading: the reported road direction minus the true
  tangent there.
* ALVINN — lateral: the distance of its road point (arc ∩ road centre) from the true centre line;
  heading: the direction of its chord to the road point minus that of the true centre point at
  the same look-ahead (the steering direction error).

A frame fails when the follower reports no road, or its lateral error exceeds `FAIL_LATERAL_M` or
its heading error `FAIL_HEADING_DEG`. Percentiles are over the frames that reported a road. Frames
whose road in view lies at least `SHADOW_SHARE` in shadow (the composition root measures it from
truth) are also summarised apart: where shadows cross the road.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator

import numpy as np

from modules.road_following import RoadFollower, RoadObservation, VehicleMotion
from wire.se2 import PoseFields, wrap_angle
from wire.summary import percentile

__all__ = ["FAIL_LATERAL_M", "FAIL_HEADING_DEG", "SHADOW_SHARE", "DrivePose", "EvalFrame", "FrameScore", "plan_drive", "to_vehicle",
           "centre_at_origin", "score_frame", "evaluate", "summarise",
           "LOCK_LATERAL_M", "LOCK_HEADING_DEG", "plan_starts", "LockOn", "lock_on", "evaluate_starts", "summarise_starts",
           "IntersectionTruth", "IntersectionScore", "score_intersection", "summarise_intersection"]

FAIL_LATERAL_M = 1.0
FAIL_HEADING_DEG = 10.0
#: A frame shows shadows across the road when at least this share of the road in view lies in shadow.
SHADOW_SHARE = 0.1


@dataclass(frozen=True)
class DrivePose(PoseFields):
    """A true pose on the drive: leg index, world pose (x [m], y [m], yaw [rad]), sim time [s]."""

    leg: int
    x: float
    y: float
    yaw: float
    stamp: float


@dataclass(frozen=True)
class EvalFrame:
    """One frame: the pose, the camera image (H, W, 3) uint8, the route centre line (N, 2) [m] in `world`, the road's shaded share."""

    pose: DrivePose
    image: np.ndarray
    centre_world: np.ndarray
    road_shadow: float | None = None  # share (0–1) of the road 5–20 m ahead in shadow (truth); None: not measured


@dataclass(frozen=True)
class FrameScore:
    """One frame's outcome: reported a road, lateral error [m], heading error [deg], wall and CPU time [ms], shadow across the road."""

    found: bool
    lateral_err_m: float
    heading_err_deg: float
    wall_ms: float
    cpu_ms: float
    shadow: bool = False


def _resample(poly: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return points every `step` [m] along `poly` (N, 2), their arc length [m] and tangent heading [rad]."""
    seg = np.diff(poly, axis=0)
    ln = np.linalg.norm(seg, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(ln)])
    s = np.arange(0.0, cum[-1] + 1e-9, step)
    i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
    t = (s - cum[i]) / np.maximum(ln[i], 1e-12)
    pts = poly[i] + t[:, None] * seg[i]
    return pts, s, np.arctan2(seg[i, 1], seg[i, 0])


def plan_drive(legs: list[np.ndarray], frames: int, rng: np.random.Generator, *, step_m: float = 3.0, lane_offset_m: float = 0.0,
               weave_m: float = 0.6, weave_period_m: float = 40.0, heading_noise_deg: float = 1.0,
               speed_mps: float = 4.2) -> list[DrivePose]:
    """Return up to `frames` poses every `step_m` [m] along the legs (world polylines), weaving `weave_m` [m] about the lane.

    The vehicle keeps `lane_offset_m` [m] left of the centre line (negative: right), heads along its
    weave plus a little noise, and moves at `speed_mps` [m/s] (sets the stamps): 3 m at 4.2 m/s is a
    frame every 0.7 s, YARF's 15 km/h with under a second per frame.
    """
    lengths = np.array([float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) for p in legs])
    if float(lengths.sum()) <= 0 or frames < 1:
        return []
    step = step_m
    out: list[DrivePose] = []
    phase = float(rng.uniform(0.0, 2.0 * math.pi))
    s_run = 0.0
    for li, poly in enumerate(legs):
        pts, s, hd = _resample(poly, step)
        for p, si, h in zip(pts, s, hd):
            if len(out) >= frames:
                return out
            w = 2.0 * math.pi * (s_run + si) / weave_period_m + phase
            off = lane_offset_m + weave_m * math.sin(w)
            dpsi = math.atan(weave_m * 2.0 * math.pi / weave_period_m * math.cos(w)) + math.radians(float(rng.normal(0.0, heading_noise_deg)))
            out.append(DrivePose(leg=li, x=float(p[0] - off * math.sin(h)), y=float(p[1] + off * math.cos(h)), yaw=float(h + dpsi),
                                 stamp=(s_run + float(si)) / speed_mps))
        s_run += float(lengths[li])
    return out


def to_vehicle(xy: np.ndarray, pose: DrivePose) -> np.ndarray:
    """Map world points (N, 2) [m] into the `vehicle` frame of `pose`."""
    return pose.to_pose2d().apply_inverse(xy)


def centre_at_origin(centre_v: np.ndarray) -> tuple[float, float] | None:
    """Return (y [m], heading [rad]) where the centre line (N, 2) in `vehicle` crosses x = 0 nearest the vehicle."""
    x = centre_v[:, 0]
    best = None
    for i in np.flatnonzero((x[:-1] <= 0.0) & (x[1:] > 0.0) | (x[:-1] > 0.0) & (x[1:] <= 0.0)):
        a, b = centre_v[i], centre_v[i + 1]
        t = -a[0] / (b[0] - a[0])
        y = float(a[1] + t * (b[1] - a[1]))
        d = b - a if b[0] > a[0] else a - b
        if best is None or abs(y) < abs(best[0]):
            best = (y, math.atan2(float(d[1]), float(d[0])))
    return best


def _signed_distance(p: np.ndarray, poly: np.ndarray) -> float:
    """Return the distance [m] from point p (2,) to the polyline (N, 2) (+ when the point is left of it)."""
    a, b = poly[:-1], poly[1:]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-12), 0.0, 1.0)
    q = a + t[:, None] * ab
    d = np.linalg.norm(p - q, axis=1)
    i = int(np.argmin(d))
    side = ab[i, 0] * (p[1] - a[i, 1]) - ab[i, 1] * (p[0] - a[i, 0])
    return float(math.copysign(d[i], side))


def _ahead_at(centre_v: np.ndarray, dist: float) -> np.ndarray | None:
    """Return where the centre line (N, 2) in `vehicle` first meets the circle of radius `dist` [m] ahead of the vehicle."""
    a, b = centre_v[:-1], centre_v[1:]
    d = b - a
    qa = (d * d).sum(1)
    qb = 2.0 * (a * d).sum(1)
    qc = (a * a).sum(1) - dist * dist
    disc = qb * qb - 4.0 * qa * qc
    for i in np.flatnonzero(disc >= 0.0):
        for sign in (1.0, -1.0):
            t = (-qb[i] + sign * math.sqrt(disc[i])) / (2.0 * max(qa[i], 1e-12))
            p = a[i] + t * d[i]
            if 0.0 <= t <= 1.0 and p[0] > 0.0:
                return p
    return None


def _angle_deg(a: float) -> float:
    return math.degrees(wrap_angle(a))


def score_frame(obs: RoadObservation, centre_v: np.ndarray, cpu_ms: float) -> FrameScore | None:
    """Score one observation against the true centre line (N, 2) in `vehicle`; None when the truth is undefined here."""
    if obs.method == "alvinn":
        if obs.road_point is None:
            return FrameScore(False, math.nan, math.nan, obs.ms_per_frame, cpu_ms)
        rp = np.asarray(obs.road_point, float)
        target = _ahead_at(centre_v, float(np.hypot(*rp)))
        if target is None:
            return None
        lat = abs(_signed_distance(rp, centre_v))
        hd = abs(_angle_deg(math.atan2(rp[1], rp[0]) - math.atan2(target[1], target[0])))
        return FrameScore(obs.found, lat, hd, obs.ms_per_frame, cpu_ms)
    truth = centre_at_origin(centre_v)
    if truth is None:
        return None
    if obs.lateral_offset_m is None or obs.heading_rad is None:
        return FrameScore(False, math.nan, math.nan, obs.ms_per_frame, cpu_ms)
    return FrameScore(obs.found, abs(obs.lateral_offset_m - truth[0]), abs(_angle_deg(obs.heading_rad - truth[1])),
                      obs.ms_per_frame, cpu_ms)


def evaluate(frames: Iterable[EvalFrame], make_follower: Callable[[EvalFrame], RoadFollower], *,
             rng: np.random.Generator, odometry_noise: tuple[float, float] = (0.01, math.radians(0.1))) -> Iterator[FrameScore]:
    """Run a fresh follower over each leg's frames and yield each frame's score; odometry is the true motion plus noise."""
    follower: RoadFollower | None = None
    prev: EvalFrame | None = None
    for fr in frames:
        p = fr.pose
        motion = None
        if follower is None or prev is None or prev.pose.leg != p.leg:
            follower = make_follower(fr)
        else:
            d = to_vehicle(np.array([[p.x, p.y]]), prev.pose)[0]
            motion = VehicleMotion(dx=float(d[0] + rng.normal(0.0, odometry_noise[0])), dy=float(d[1] + rng.normal(0.0, odometry_noise[0])),
                                   dyaw=float(wrap_angle(p.yaw - prev.pose.yaw) + rng.normal(0.0, odometry_noise[1])))
        c0 = time.thread_time()
        obs = follower.observe(fr.image, stamp=p.stamp, motion=motion)
        cpu = (time.thread_time() - c0) * 1e3
        prev = fr
        sc = score_frame(obs, to_vehicle(fr.centre_world, p), cpu)
        if sc is not None:
            yield dataclasses.replace(sc, shadow=fr.road_shadow is not None and fr.road_shadow >= SHADOW_SHARE)


def _figures(scores: list[FrameScore]) -> dict:
    """Return the figures of some frames: lateral / heading error p50 and p95, failure rate."""
    n = len(scores)
    ok = [s for s in scores if s.found and math.isfinite(s.lateral_err_m)]
    fails = sum(1 for s in scores if not s.found or not math.isfinite(s.lateral_err_m) or s.lateral_err_m > FAIL_LATERAL_M
                or s.heading_err_deg > FAIL_HEADING_DEG)

    lat = [s.lateral_err_m for s in ok]
    hd = [s.heading_err_deg for s in ok]
    return {
        "frames": n,
        "frames_with_road": len(ok),
        "lateral_error_m_p50": percentile(lat, 50, digits=4),
        "lateral_error_m_p95": percentile(lat, 95, digits=4),
        "heading_error_deg_p50": percentile(hd, 50, digits=4),
        "heading_error_deg_p95": percentile(hd, 95, digits=4),
        "failure_rate": round(fails / n, 4) if n else None,
    }


def summarise(scores: list[FrameScore]) -> dict:
    """Return the figures (see `_figures`) of all frames, ms per frame (wall and CPU) p50, and those of the frames with shadows across the road."""

    out = _figures(scores)
    out["ms_per_frame_p50"] = percentile([s.wall_ms for s in scores], 50, digits=4)
    out["cpu_ms_per_frame_p50"] = percentile([s.cpu_ms for s in scores], 50, digits=4)
    out.update({f"shadow_{k}": v for k, v in _figures([s for s in scores if s.shadow]).items()})
    return out


# ---- issue 41: lock-on from no prior (YARF's bootstrap, Navlab 1990 §5.5) ----------------------------------------

#: A follower has locked on when its road is within these of the truth (YARF tracks at 0.08 m and 1.8° p95) and it
#: holds the road from then on (no frame without it, none off by the failure bounds).
LOCK_LATERAL_M = 0.3
LOCK_HEADING_DEG = 3.0


def plan_starts(legs: list[np.ndarray], starts: int, frames: int, rng: np.random.Generator, *, step_m: float = 3.0,
                lane_offset_m: float = 0.0, max_offset_m: float = 2.0, max_heading_deg: float = 10.0,
                speed_mps: float = 4.2) -> list[list[DrivePose]]:
    """Return `starts` runs of `frames` poses `step_m` apart at random places on the legs, each off its lane by up to
    ±`max_offset_m` [m] and ±`max_heading_deg` [deg] (uniform), held for the run: the hardest view of each start kept.

    Each run's `leg` is its leg's index; a run needs `frames × step_m` of its leg (legs too short are skipped).
    """
    need = frames * step_m
    usable = [i for i, p in enumerate(legs) if float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) > need]
    if not usable:
        return []
    out = []
    for _ in range(starts):
        li = usable[int(rng.integers(len(usable)))]
        pts, s, hd = _resample(legs[li], step_m)
        k0 = int(rng.integers(0, len(pts) - frames + 1))
        off = lane_offset_m + float(rng.uniform(-max_offset_m, max_offset_m))
        dpsi = math.radians(float(rng.uniform(-max_heading_deg, max_heading_deg)))
        run = []
        for k in range(k0, k0 + frames):
            p, h = pts[k], float(hd[k])
            run.append(DrivePose(leg=li, x=float(p[0] - off * math.sin(h)), y=float(p[1] + off * math.cos(h)), yaw=h + dpsi,
                                 stamp=float(s[k]) / speed_mps))
        out.append(run)
    return out


@dataclass(frozen=True)
class LockOn:
    """One start: the frame (1-based) from which the follower stayed locked to the end, None if it never did; frames run."""

    frame: int | None
    frames: int


def lock_on(scores: list[FrameScore | None]) -> LockOn:
    """Return when a start's follower locked on: the first frame found within LOCK_LATERAL_M and LOCK_HEADING_DEG of the
    truth after which every frame is found and no failure (within FAIL_LATERAL_M and FAIL_HEADING_DEG)."""
    def near(s: FrameScore | None) -> bool:
        return s is not None and s.found and s.lateral_err_m <= LOCK_LATERAL_M and s.heading_err_deg <= LOCK_HEADING_DEG

    def held(s: FrameScore | None) -> bool:
        return s is not None and s.found and s.lateral_err_m <= FAIL_LATERAL_M and s.heading_err_deg <= FAIL_HEADING_DEG

    first = None
    for i in range(len(scores) - 1, -1, -1):
        if not held(scores[i]):
            break
        if near(scores[i]):
            first = i + 1
    return LockOn(first, len(scores))


def evaluate_starts(runs: Iterable[list[EvalFrame]], make_follower: Callable[[EvalFrame], RoadFollower], *,
                    rng: np.random.Generator, odometry_noise: tuple[float, float] = (0.01, math.radians(0.1))) -> Iterator[LockOn]:
    """Run a fresh follower over each start's frames (no prior: the follower's own bootstrap) and yield when it locked on."""
    for frames in runs:
        follower = None
        prev: EvalFrame | None = None
        scores: list[FrameScore | None] = []
        for fr in frames:
            motion = None
            if follower is None:
                follower = make_follower(fr)
            elif prev is not None:
                d = to_vehicle(np.array([[fr.pose.x, fr.pose.y]]), prev.pose)[0]
                motion = VehicleMotion(dx=float(d[0] + rng.normal(0.0, odometry_noise[0])), dy=float(d[1] + rng.normal(0.0, odometry_noise[0])),
                                       dyaw=float(wrap_angle(fr.pose.yaw - prev.pose.yaw) + rng.normal(0.0, odometry_noise[1])))
            obs = follower.observe(fr.image, stamp=fr.pose.stamp, motion=motion)
            scores.append(score_frame(obs, to_vehicle(fr.centre_world, fr.pose), 0.0))
            prev = fr
        yield lock_on(scores)


def summarise_starts(locks: list[LockOn], within: int = 5) -> dict:
    """Return the lock-on figures: starts, the share locked within `within` frames and at all, frames to lock p50 / p95 / max."""
    n = len(locks)
    got = [lk.frame for lk in locks if lk.frame is not None]
    return {
        "starts": n,
        f"lock_rate_within_{within}": round(sum(1 for f in got if f <= within) / n, 4) if n else None,
        "lock_rate": round(len(got) / n, 4) if n else None,
        "frames_to_lock_p50": percentile(got, 50),
        "frames_to_lock_p95": percentile(got, 95),
        "frames_to_lock_max": max(got) if got else None,
        "lock_lateral_m": LOCK_LATERAL_M,
        "lock_heading_deg": LOCK_HEADING_DEG,
    }


# ---- issue 41: YARF through an intersection (Navlab 1990 §5.6) ---------------------------------------------------

@dataclass(frozen=True)
class IntersectionTruth:
    """The truth of one frame near an intersection: distance [m] along the route to its near edge (negative: past it), the
    branch's centre line and the lane to turn into, each as a point and a unit direction in `world`."""

    distance_m: float
    branch_point: tuple[float, float]
    branch_dir: tuple[float, float]
    lane_point: tuple[float, float]


@dataclass(frozen=True)
class IntersectionScore:
    """One frame's intersection figures (NaN where the navigator has no answer yet)."""

    distance_m: float
    detected: bool
    approach_err_m: float
    junction_err_m: float  # the branch's origin from the true branch centre line [m]
    angle_err_deg: float
    path_end_err_m: float  # the path's end from the true lane's centre line [m]
    path_heading_err_deg: float


def _line_distance(p: np.ndarray, point: np.ndarray, direction: np.ndarray) -> float:
    d = p - point
    return float(abs(d[0] * direction[1] - d[1] * direction[0]))


def score_intersection(view, pose: DrivePose, truth: IntersectionTruth) -> IntersectionScore:
    """Score an `IntersectionView` (vehicle frame) against the truth (world frame)."""
    nan = math.nan
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)

    def world(p):
        return np.array([pose.x + c * p[0] - s * p[1], pose.y + s * p[0] + c * p[1]])

    bp, bd, lp = (np.asarray(v, float) for v in (truth.branch_point, truth.branch_dir, truth.lane_point))
    if view.approach_m is None:
        return IntersectionScore(truth.distance_m, False, nan, nan, nan, nan, nan)
    approach = abs(view.approach_m - truth.distance_m)
    if view.branch is None:
        return IntersectionScore(truth.distance_m, True, approach, nan, nan, nan, nan)
    b = view.branch
    origin = world((b.along_m, 0.0))  # the branch leaves the road's centre at along_m on the vehicle's axis: its junction point
    ang = abs(_angle_deg(b.angle_rad + pose.yaw - math.atan2(bd[1], bd[0])))
    junction = _line_distance(origin, bp, bd)
    end_err = hd_err = nan
    if len(view.path) >= 2:
        p = np.array([world(q) for q in view.path[-2:]])
        end_err = _line_distance(p[-1], lp, bd)
        hd_err = abs(_angle_deg(math.atan2(*(p[-1] - p[-2])[::-1]) - math.atan2(bd[1], bd[0])))
    return IntersectionScore(truth.distance_m, True, approach, junction, ang, end_err, hd_err)


def summarise_intersection(runs: list[list[IntersectionScore]]) -> dict:
    """Return the figures over runs: detection distance, false alarms, approach error, and the branch and the path at entry.

    A false alarm is a detection on the approach more than 5 m off the true distance (past the near edge the vehicle turns
    and its distance along its own axis is no longer the route's). "At entry" is the last frame before the near edge.
    """
    def pct(vals: list[float], q: float) -> float | None:
        return percentile([v for v in vals if math.isfinite(v)], q, digits=3)

    first, false, approach, entry = [], 0, [], []
    for sc in runs:
        det = [x for x in sc if x.detected]
        first.append(det[0].distance_m if det else math.nan)
        false += sum(1 for x in det if x.distance_m > 0 and x.approach_err_m > 5.0)
        approach += [x.approach_err_m for x in det if x.distance_m > 0]
        before = [x for x in sc if x.distance_m > 0]
        if before:
            entry.append(before[-1])
    return {
        "runs": len(runs),
        "detected_runs": sum(1 for f in first if math.isfinite(f)),
        "detection_distance_m_min": pct(first, 0),
        "detection_distance_m_p50": pct(first, 50),
        "false_alarm_frames": false,
        "approach_error_m_p50": pct(approach, 50),
        "approach_error_m_p95": pct(approach, 95),
        "junction_error_m_at_entry_p50": pct([e.junction_err_m for e in entry], 50),
        "junction_error_m_at_entry_max": pct([e.junction_err_m for e in entry], 100),
        "branch_angle_error_deg_at_entry_p50": pct([e.angle_err_deg for e in entry], 50),
        "branch_angle_error_deg_at_entry_max": pct([e.angle_err_deg for e in entry], 100),
        "path_end_error_m_at_entry_p50": pct([e.path_end_err_m for e in entry], 50),
        "path_end_error_m_at_entry_max": pct([e.path_end_err_m for e in entry], 100),
        "path_heading_error_deg_at_entry_max": pct([e.path_heading_err_deg for e in entry], 100),
    }
