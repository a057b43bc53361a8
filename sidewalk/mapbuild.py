"""Build a map of discrete objects by driving a route (seed: Navlab 1990 §1.2.4).

The vehicle drives a mission's route on the map's path graph (the roads come from the map file: the
path graph is known, the objects are being built) by what the robot knows of where it is, never by
the truth: the drive loop (`drive_route`) is handed a `MappingVehicle` that takes drive commands and
gives odometry and sensor frames, nothing else. The robot believes it starts at the map's start pose
and keeps its estimate as a CODGER mission does: the PILOT's filter (`modules.pilot.kalman.PoseFilter`
behind its fix gate, `modules.pilot.fix_gate`) predicted by odometry and corrected by PERCEPTION's
position fixes (the pipeline on a colored-range frame every `perceive_m` of travel, the map's objects
ahead of the estimate predicted; Sidewalk 1986 §3.4) and by laser landmark fixes against the map's
landmarks (the OBSTACLE DETECTOR's matching, `modules.perception.landmarks`, at most one a second,
behind the PILOT's χ² gate; Navlab 1990 §2.5.4). It steers along the route's lane (keep right) by that estimate
and stops where it believes the route ends, `END_SHORT_M` short of it. The simulator puts the vehicle
where the world starts it, so the map's start error and odometry's drift are the drive's own.

Where each laser frame was taken comes from "road-matched" dead reckoning: the distance travelled,
by odometry, along the known lane of the route, frames on bends skipped. Odometry's distance drifts
(a scale error of ~1 % is 5 m over the AMV route), so the distance is re-anchored at each sharp turn
of the route: where the odometry heading has turned half of it the vehicle is at the turn's middle on
the map's lane (`turn_anchors`); between anchors the odometry distance is stretched to the map's,
past the last one at the last interval's scale. At every `step_m` of travel the laser is read;
obstacles small enough to be trees, posts, mailboxes become vehicle-frame observations; after the
drive each frame is placed on the lane at its anchored distance, the observations put in the `world`
frame there, and the `ObjectTracker` folds them in frame by frame (confidence up when seen, down
when missed where it should appear, maximum-likelihood positions, moving and spurious objects
dropped). The built map is the map file's ground (roads, lawns, buildings, path graph) with its
discrete objects replaced by the built ones, written as GeoJSON a later run takes with
`sidewalk run --map FILE`. Truth (the world) is read here only by the simulated vehicle (its
sensors and physics) and to score the built map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict

from modules.map_navigator.mapdata import map_object
from codger.obstacles.detector import ObstacleDetectorConfig
from modules.perception.landmarks import (
    LandmarkConfig, LandmarkObservation, MapLandmark, landmark_fix, landmark_observations, map_landmarks, match_landmarks,
)
from modules.perception.object_tracker import ObjectTracker, TrackedObject, TrackerConfig, WorldObservation
from modules.perception.image import ColoredRangeImage
from modules.perception.monitor import SENSORS, ResolutionTable
from modules.perception.obstacles import LaserScan, detect_obstacles
from modules.perception.pipeline import PerceptionPipeline
from modules.perception.results import position_fix
from modules.pilot.config import pilot_config_for
from modules.pilot.fix_gate import FixGate
from modules.pilot.kalman import EstimatorError, FixRefused, PointFix, PoseFilter
from codger.pilot.position_estimator import filter_fix
from modules.vocabulary import MapObject
from wire.drive import DriveCommand, Odometry
from wire.se2 import wrap_angle

__all__ = ["MapBuildReport", "BuiltMap", "DISCRETE_KINDS", "END_SHORT_M", "MappingVehicle", "Sensed", "SimulatedVehicle", "DriveLog",
           "route_polyline", "route_lane", "objects_ahead", "drive_route", "build_map", "score_map", "write_map", "turn_anchors",
           "anchored_distance"]

#: How far [m] before the route's end (as the robot believes it) the mapping drive stops.
END_SHORT_M = 1.0

#: Kinds of map objects that are discrete objects the laser maps (the rest is ground and buildings).
DISCRETE_KINDS = ("tree", "mailbox", "sign", "hydrant", "lamp_post", "bench", "rock")

#: The robot's uncertainty about the map's start pose: std of x, y [m] and heading [rad].
START_SIGMA = (0.5, 0.5, math.radians(2.0))


class MapBuildReport(BaseModel):
    """The built map against truth: per-object error [m] (mean, max), matched / spurious / missed counts.

    `odometry_error_final_m` [m] is where the robot believed it stopped against where it truly stood;
    `perception_fixes` and `landmark_fixes` how many fixes its estimate took on the way.
    """

    model_config = ConfigDict(frozen=True)

    frames: int
    distance_m: float
    built_objects: int
    matched: int
    spurious: int
    missed: int
    error_mean_m: float | None
    error_max_m: float | None
    dropped_moving: int
    dropped_spurious: int
    odometry_error_final_m: float
    perception_fixes: int = 0
    landmark_fixes: int = 0
    map_file: str


@dataclass
class BuiltMap:
    """The tracker's objects after the drive, `world` frame (dead-reckoned), and the drive's figures."""

    objects: list[TrackedObject]
    frames: int
    distance_m: float
    dropped_moving: int
    dropped_spurious: int
    odometry_error_final_m: float
    perception_fixes: int = 0
    landmark_fixes: int = 0


class MappingVehicle(Protocol):
    """What the mapping drive may use of the vehicle: drive commands in, odometry and laser scans out (no truth)."""

    def command(self, cmd: DriveCommand) -> None:
        """Send a drive command."""

    def advance(self, dt: float) -> Odometry:
        """Let `dt` [s] sim pass; return the odometry (`local` frame) then."""

    def sense(self, camera: bool) -> "Sensed":
        """Return the laser image taken now, and with `camera` the colored-range frame of the same capture."""


@dataclass(frozen=True)
class Sensed:
    """One capture as the robot reads it: the laser image, and (asked for) the colored-range frame (`vehicle` frame)."""

    scan: LaserScan
    image: ColoredRangeImage | None = None


class SimulatedVehicle:
    """A `MappingVehicle` in the simulator: started where the world starts it; the truth stays inside (`true_xy` is for scoring)."""

    def __init__(self, world, *, actors=None, vehicle: str = "navlab", seed: int = 0, odometry=None) -> None:
        """Put the vehicle at the world's start in `world` with `actors` (objects not on the map); noise from `seed`,
        odometry's errors from `odometry` (`vehicle_sim.odometry.OdometryModel`; None: the simulator's default)."""
        from vehicle_sim.scene import Scene
        from vehicle_sim.simulator import SimConfig, Simulator

        odo = {} if odometry is None else {"odometry": odometry}
        self._sim = Simulator(world, SimConfig(vehicle=vehicle, seed=seed, physics_hz=50.0, collisions_block=False, **odo),  # type: ignore[arg-type]
                              actors=actors)
        self._scene = Scene(world, seed=seed)
        self._actors = actors if actors is not None and len(actors) else None
        if self._actors is not None:
            self._scene.add_actors(self._actors)
        self._rng = np.random.default_rng([seed, 0x3A9])
        self._vehicle = vehicle

    def command(self, cmd: DriveCommand) -> None:
        """Send a drive command to the simulator."""
        self._sim.submit(cmd)

    def advance(self, dt: float) -> Odometry:
        """Step the simulator `dt` [s]; return its odometry."""
        self._sim.advance(dt)
        return self._sim.odometry()

    def sense(self, camera: bool) -> Sensed:
        """Render the laser (and with `camera` the camera) at the true pose now; hand over what PERCEPTION reads."""
        from modules.perception.sensor_frame import SensorFrame, colored_range_image
        from vehicle_sim.sensors import CaptureRequest, capture

        sim = self._sim
        scene = self._scene.at_time(self._actors, sim.t) if self._actors is not None else self._scene
        cap = capture(scene, (sim.state.x, sim.state.y, sim.state.yaw), sim.t, CaptureRequest(camera=camera),
                      vehicle=self._vehicle, rng=self._rng)
        return Sensed(scan=LaserScan.from_capture(cap), image=colored_range_image(SensorFrame.from_fields(cap)) if camera else None)

    def true_xy(self) -> tuple[float, float]:
        """Return the true position (x, y) [m] `world` now: for scoring the drive, never for driving it."""
        return (float(self._sim.state.x), float(self._sim.state.y))


@dataclass
class DriveLog:
    """What the drive recorded: the odometry heading trace (N, 2: odometry distance [m], believed heading [rad]),
    the laser observations per frame (odometry distance [m], vehicle-frame landmark observations), the odometry
    distance [m] driven, whether it reached the route's end by its estimate, its final estimate (x, y [m], yaw [rad],
    `world`), and the fixes it used and refused: PERCEPTION's and the laser landmarks'."""

    heading: np.ndarray
    shots: list[tuple[float, list[LandmarkObservation]]]
    distance_m: float
    arrived: bool
    estimate: tuple[float, float, float]
    perception_fixes: int = 0
    perception_refused: int = 0
    landmark_fixes: int = 0
    landmark_refused: int = 0


def route_polyline(map_world, mission) -> np.ndarray:
    """Return the mission's route on the map's path graph as one polyline (K, 2) [m], `world` frame."""
    from modules.map_navigator.mapdata import MapData
    from modules.map_navigator.route import RouteOptions, select_route

    m = MapData(map_world)
    start = (map_world.start.x, map_world.start.y)
    pts: list[np.ndarray] = []
    for step in mission.steps:
        route = select_route(m, start, step.destination, step.constraints, RouteOptions(vehicle=mission.vehicle or "navlab"))
        for leg in route.legs:
            c = np.asarray(leg.coords, np.float64)
            pts.append(c if not pts else c[1:])
        start = route.goal_xy
    out = np.concatenate(pts)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(out, axis=0), axis=1) > 1e-6])
    return out[keep]


def route_lane(path: np.ndarray, lane_offset: float) -> np.ndarray:
    """Return the polyline `path` (K, 2) [m] moved `lane_offset` [m] to the right of its direction at each vertex (keep right)."""
    seg = np.diff(path, axis=0)
    nrm = np.stack([seg[:, 1], -seg[:, 0]], -1) / np.maximum(np.linalg.norm(seg, axis=1, keepdims=True), 1e-9)
    nrm = np.vstack([nrm, nrm[-1:]])
    return path + lane_offset * nrm


def _lookahead_point(path: np.ndarray, xy: np.ndarray, ahead: float) -> tuple[np.ndarray, float, float]:
    """Return (point `ahead` [m] past the projection of xy, arc length there, total length)."""
    seg = np.diff(path, axis=0)
    ln = np.linalg.norm(seg, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(ln)])
    t = np.clip(((xy - path[:-1]) * seg).sum(1) / np.maximum(ln ** 2, 1e-12), 0, 1)
    proj = path[:-1] + t[:, None] * seg
    i = int(np.argmin(np.linalg.norm(proj - xy, axis=1)))
    s = cum[i] + t[i] * ln[i]
    s_t = min(s + ahead, cum[-1])
    j = int(min(np.searchsorted(cum, s_t) , len(path) - 1))
    j = max(j, 1)
    f = (s_t - cum[j - 1]) / max(ln[j - 1], 1e-9)
    return path[j - 1] + f * seg[j - 1], s, float(cum[-1])


def _landmark_fix(est: PoseFilter, obs: list[LandmarkObservation], marks: list[MapLandmark], cfg: ObstacleDetectorConfig,
                  gate: float) -> bool | None:
    """Correct `est` by the map landmarks `obs` match at its pose; return whether the fix was used (None: no fix)."""
    x, y, yaw = est.pose
    near = [m for m in marks if math.hypot(m.x - x, m.y - y) <= cfg.landmark.max_range + 5.0 + 3.0 * math.sqrt(est.cov[0, 0] + est.cov[1, 1])]
    # the gate allows for what the estimate is unsure of (at least the detector's prior σ): a drifted estimate still matches
    prior = est.cov[:2, :2] + np.eye(2) * cfg.prior_sigma_m ** 2
    fix = landmark_fix(match_landmarks(obs, near, (float(x), float(y), float(yaw)), pose_cov=prior, cfg=cfg.landmark))
    if fix is None:
        return None
    cov = np.asarray(fix.cov, np.float64)
    try:
        est.update_position(np.array([x + fix.dx, y + fix.dy]), 0.5 * (cov + cov.T), gate=gate)
    except EstimatorError:
        return False
    return True


def objects_ahead(objects: tuple[MapObject, ...], pose: tuple[float, float, float], reach: float = 24.0) -> tuple[MapObject, ...]:
    """Return the map objects whose footprint meets a fan `reach` [m] ahead of `pose` (x, y [m], yaw [rad], `world`)."""
    from shapely.geometry import Point, Polygon

    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    fan = Polygon([(x + c * a - s * b, y + s * a + c * b) for a, b in ((0.0, -1.0), (reach, -0.9 * reach), (reach, 0.9 * reach), (0.0, 1.0))])
    return tuple(o for o in objects if (Polygon(o.polygon) if o.polygon is not None else Point(o.center).buffer(o.radius or 0.1)).intersects(fan))


def _perception_fix(est: PoseFilter, gate: FixGate, pipe: PerceptionPipeline, image: ColoredRangeImage,
                    objects: tuple[MapObject, ...]) -> bool | None:
    """Correct `est` by PERCEPTION's fix on `image` at its pose; return whether it was used (None: no fix)."""
    pose = tuple(float(v) for v in est.pose)
    allowance = float(np.clip(2.0 * math.sqrt(max(est.cov[0, 0], est.cov[1, 1])), 0.5, 3.0))  # the driving unit's
    fix = position_fix(pipe.process(image, objects_ahead(objects, pose), pose, error_allowance=allowance).calibration)
    if fix is None:
        return None
    meas = filter_fix(fix)
    try:
        if isinstance(meas, PointFix):
            est.update_point(meas)
        else:
            est.update_line(meas)
    except FixRefused:
        gate.on_refused(est)
        return False
    except EstimatorError:
        return None
    gate.on_used()
    return True


def drive_route(car: MappingVehicle, lane: np.ndarray, start: tuple[float, float, float], *, vehicle: str = "navlab",
                speed: float = 4.0, step_m: float = 1.5, landmarks: LandmarkConfig = LandmarkConfig(),
                map_marks: list[MapLandmark] | tuple[MapLandmark, ...] = (), map_objects: tuple[MapObject, ...] = (),
                perceive_m: float = 4.0, max_s: float = 3600.0) -> DriveLog:
    """Drive `car` along `lane` (K, 2) [m] `world` by its estimate from the believed `start` (x, y [m], yaw [rad]).

    The estimate is the PILOT's filter on odometry, corrected by PERCEPTION's fixes against `map_objects`
    every `perceive_m` [m] and by laser landmark fixes against `map_marks` (none of either: dead reckoning
    alone); pure pursuit steers to a point ahead on the lane; the drive stops `END_SHORT_M` before the
    lane's end as the estimate has it (or after `max_s` [s] sim). Every `step_m` [m] of odometry a laser
    scan's small obstacles become landmark observations.
    """
    cfg = pilot_config_for(vehicle)  # type: ignore[arg-type]
    est = PoseFilter(np.asarray(start, np.float64), np.diag(np.square(START_SIGMA)), cfg.odometry, gate=cfg.fix_gate)
    fix_gate, pipe = FixGate(), PerceptionPipeline(ResolutionTable(SENSORS[vehicle]), speed=speed)
    det, gate = ObstacleDetectorConfig(), cfg.landmark_gate
    marks = list(map_marks)
    last_fix, fixes, refused = -math.inf, 0, 0
    last_seen, seen, unseen = -math.inf, 0, 0
    kmax = 1.0 / 7.0 if vehicle == "navlab" else 2.0
    heading: list[tuple[float, float]] = []
    shots: list[tuple[float, list[LandmarkObservation]]] = []
    od = car.advance(0.0)
    last_pose, last_cap, t, seq, arrived = np.array([od.x, od.y, od.yaw]), -math.inf, 0.0, 0, False
    while t < max_s:
        x, y, yaw = est.pose
        target, s, total = _lookahead_point(lane, np.array([x, y]), max(4.0, 1.2 * od.v + 3.0))
        if total - s < END_SHORT_M:
            arrived = True
            break
        dx, dy = target[0] - x, target[1] - y
        c, si = math.cos(yaw), math.sin(yaw)
        lx, ly = c * dx + si * dy, -si * dx + c * dy
        kappa = float(np.clip(2.0 * ly / max(lx * lx + ly * ly, 1e-6), -kmax, kmax))
        seq += 1
        car.command(DriveCommand(speed=min(speed, 1.0 + (total - s) * 0.5), curvature=kappa, duration=1.0, seq=seq))
        od = car.advance(0.1)
        t += 0.1
        pose = np.array([od.x, od.y, od.yaw])
        est.predict(PoseFilter.motion(last_pose, pose))
        last_pose = pose
        heading.append((od.distance, float(start[2]) + od.yaw))
        look = bool(map_objects) and od.distance - last_seen >= perceive_m
        if od.distance - last_cap >= step_m or look:
            sensed = car.sense(camera=look)
            if look and sensed.image is not None:
                last_seen = od.distance
                used = _perception_fix(est, fix_gate, pipe, sensed.image, map_objects)
                seen, unseen = seen + (used is True), unseen + (used is False)
        if od.distance - last_cap >= step_m:
            last_cap = od.distance
            obs = landmark_observations(detect_obstacles(sensed.scan), landmarks)
            shots.append((od.distance, obs))
            if marks and obs and t - last_fix >= det.landmark_period_s:
                used = _landmark_fix(est, obs, marks, det, gate)
                if used is not None:
                    last_fix = t
                    fixes, refused = fixes + used, refused + (not used)
    p = est.pose
    return DriveLog(heading=np.asarray(heading, np.float64).reshape(-1, 2), shots=shots, distance_m=float(od.distance),
                    arrived=arrived, estimate=(float(p[0]), float(p[1]), float(p[2])), perception_fixes=seen,
                    perception_refused=unseen, landmark_fixes=fixes, landmark_refused=refused)


def build_map(world, map_world, mission, *, actors=None, vehicle: str = "navlab", seed: int = 0, speed: float = 4.0,
              lane_offset: float = 1.5, step_m: float = 1.5, tracker: TrackerConfig = TrackerConfig(),
              landmarks: LandmarkConfig = LandmarkConfig()) -> BuiltMap:
    """Drive the mission's route in `world` from the map's start by the robot's estimate; track the objects the laser finds."""
    lane = route_lane(route_polyline(map_world, mission), lane_offset)
    ms = map_world.start
    car = SimulatedVehicle(world, actors=actors, vehicle=vehicle, seed=seed)
    log = drive_route(car, lane, (ms.x, ms.y, ms.yaw), vehicle=vehicle, speed=speed, step_m=step_m, landmarks=landmarks,
                      map_marks=map_landmarks(map_world.objects), map_objects=tuple(map_object(o) for o in map_world.objects))
    anchors = turn_anchors(lane, log.heading)
    lane_cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(lane, axis=0), axis=1))])
    tr = ObjectTracker(tracker)
    frames = 0
    for dist, obs in log.shots:
        pose_w = _road_matched(lane_cum, lane, anchored_distance(anchors, dist))
        if pose_w is None:  # on a bend the vehicle leaves the lane's tangent: no observation there
            continue
        cw, sw = math.cos(pose_w[2]), math.sin(pose_w[2])
        R = np.array([[cw, -sw], [sw, cw]])
        wobs = []
        for o in obs:
            p = np.array(pose_w[:2]) + R @ np.array([o.x, o.y])
            cv = R @ np.asarray(o.cov) @ R.T
            wobs.append(WorldObservation(x=float(p[0]), y=float(p[1]), cov=((cv[0, 0], cv[0, 1]), (cv[1, 0], cv[1, 1])),
                                         size=o.size, height=o.height))
        tr.update(pose_w, wobs)
        frames += 1
    return BuiltMap(objects=tr.mapped(), frames=frames, distance_m=log.distance_m, dropped_moving=tr.dropped_moving,
                    dropped_spurious=tr.dropped_spurious,
                    odometry_error_final_m=float(math.dist(log.estimate[:2], car.true_xy())),
                    perception_fixes=log.perception_fixes, landmark_fixes=log.landmark_fixes)


def _unwrap(a: np.ndarray) -> np.ndarray:
    return np.unwrap(np.asarray(a, np.float64))


def turn_anchors(lane: np.ndarray, heading: np.ndarray, *, min_turn: float = math.radians(45.0),
                 window_m: float = 25.0) -> np.ndarray:
    """Return (K, 2) anchors (odometry distance [m], lane arc length [m]) at the middle of the lane's sharp turns, (0, 0) first.

    A turn is where the heading changes by more than `min_turn` [rad] within `window_m` [m]; its middle
    is where half of that change is done, on the lane (arc length; the corner of a polyline) and in the
    odometry trace `heading` (N, 2: odometry distance [m], heading [rad]). The turns are paired in
    order; when the counts differ (the drive did not follow the route) only the start anchors. The
    vehicle cuts a corner (a 7 m arc is ≈ 1.5 m shorter than the 90° corner it rounds, half of it
    after the middle): that much along-track error stays after the last turn.
    """
    def turns(s: np.ndarray, yaw: np.ndarray) -> list[float]:
        g = np.arange(s[0], s[-1], 0.5)  # resampled every 0.5 m
        y = np.interp(g, s, yaw)
        h = int(round(0.5 * window_m / 0.5))
        if len(g) <= 2 * h:
            return []
        change = np.zeros(len(g))
        change[h:-h] = y[2 * h:] - y[:-2 * h]  # heading change across a window centred on each sample
        on = np.abs(change) >= min_turn
        out: list[float] = []
        k = 0
        while k < len(g):
            if not on[k]:
                k += 1
                continue
            e = k
            while e + 1 < len(g) and on[e + 1]:
                e += 1
            lo, hi = max(0, k - h), min(len(g) - 1, e + h)
            half = 0.5 * (y[lo] + y[hi])
            past = np.flatnonzero(np.sign(y[hi] - y[lo]) * (y[lo:hi + 1] - half) >= 0.0)  # first sample past half-way
            out.append(float(g[lo + int(past[0])]) if len(past) else float(g[(lo + hi) // 2]))
            k = e + 1
        return out

    seg = np.diff(lane, axis=0)
    ln = np.linalg.norm(seg, axis=1)
    keep = ln > 1e-9
    cum = np.concatenate([[0.0], np.cumsum(ln[keep])])
    yaw_seg = _unwrap(np.arctan2(seg[keep, 1], seg[keep, 0]))
    # the lane's heading sampled every 0.5 m (piecewise constant between vertices)
    s_l = np.arange(0.0, cum[-1], 0.5)
    yaw_l = yaw_seg[np.clip(np.searchsorted(cum, s_l, side="right") - 1, 0, len(yaw_seg) - 1)]
    lane_turns = turns(s_l, yaw_l)
    odo_turns = turns(heading[:, 0], _unwrap(heading[:, 1])) if len(heading) > 2 else []
    out = [(0.0, 0.0)]
    if len(odo_turns) == len(lane_turns):
        out += [(a, b) for a, b in zip(odo_turns, lane_turns) if a > out[-1][0] and b > out[-1][1]]
    return np.asarray(out, np.float64)


def anchored_distance(anchors: np.ndarray, d: float) -> float:
    """Return the lane arc length [m] at odometry distance `d` [m]: stretched between `turn_anchors`, past the last
    with the last interval's scale (the raw distance when there is no turn)."""
    a = np.asarray(anchors, np.float64).reshape(-1, 2)
    if len(a) < 2:
        return float(d)
    j = int(np.clip(np.searchsorted(a[:, 0], d) - 1, 0, len(a) - 2))
    (o0, s0), (o1, s1) = a[j], a[j + 1]
    scale = (s1 - s0) / max(o1 - o0, 1e-9)
    if d >= a[-1, 0]:
        o0, s0 = a[-1]
    return float(s0 + (d - o0) * scale)


def _road_matched(cum: np.ndarray, lane: np.ndarray, s: float, straight: float = 6.0,
                  max_turn: float = math.radians(3.0)) -> tuple[float, float, float] | None:
    """Return the pose (x, y [m], yaw [rad], `world`) at odometry distance `s` [m] along the known lane, or None on a bend.

    The robot knows which road it drives (the route over the map's path graph) and how far it went
    (odometry); its heading is the lane's where the lane runs straight for ±`straight` [m].
    """
    def at(u: float) -> tuple[np.ndarray, float]:
        u = float(np.clip(u, 0.0, cum[-1]))
        j = int(np.clip(np.searchsorted(cum, u), 1, len(lane) - 1))
        d = lane[j] - lane[j - 1]
        f = (u - cum[j - 1]) / max(float(np.hypot(*d)), 1e-9)
        return lane[j - 1] + f * d, math.atan2(d[1], d[0])

    p, yaw = at(s)
    _, ya = at(s - straight)
    _, yb = at(s + straight)
    turn = max(abs(wrap_angle(ya - yaw)), abs(wrap_angle(yb - yaw)))
    if turn > max_turn:
        return None
    return float(p[0]), float(p[1]), yaw


def _kind_of(o: TrackedObject) -> str:
    """Return the map kind a built object most likely is, from its height [m] (points above 3 m are not kept)."""
    if o.height >= 2.3:
        return "tree"
    if o.height >= 1.6:
        return "sign"
    if o.height >= 0.95:
        return "mailbox"
    return "hydrant"


def write_map(map_world, built: BuiltMap, path: str | Path, *, name: str | None = None) -> Path:
    """Write the map file's ground and path graph with its discrete objects replaced by the built ones; return the path."""
    from wire.mapfile import MapColour, MapFile, PostShape, TreeShape, WorldObject

    keep = [o for o in map_world.objects if o.kind not in DISCRETE_KINDS]
    new = []
    for k, o in enumerate(sorted(built.objects, key=lambda o: (o.x, o.y))):
        kind = _kind_of(o)
        if kind == "tree":
            shape = TreeShape(trunk_radius=0.23, crown_radius=2.4, height=7.0, crown_base=2.8, z0=0.0)
            radius, colour, role = 0.23, MapColour(type="BROWN", nominal=(92.0, 72.0, 54.0)), "obstacle"
        else:
            h = {"sign": 2.4, "mailbox": 1.15, "hydrant": 0.8}[kind]
            shape = PostShape(height=h, z0=0.0)
            radius = {"sign": 0.08, "mailbox": 0.25, "hydrant": 0.2}[kind]
            colour, role = MapColour(type="GRAY", nominal=(120.0, 110.0, 100.0)), "landmark"
        new.append(WorldObject(id=f"built_{kind}_{k:03d}", kind=kind, role=role, colour=colour, shape=shape,
                               center=(round(o.x, 3), round(o.y, 3)), radius=radius))
    m = MapFile(name=name or map_world.name, objects=keep + new, nodes=map_world.nodes, edges=map_world.edges, sun=map_world.sun,
                start=map_world.start, source=str(path))
    return m.save(path)


def score_map(world, built: BuiltMap, route: np.ndarray, *, match_m: float = 1.5, corridor_m: float = 10.0) -> dict:
    """Return per-object error [m] (mean, max) of the built objects against the world's discrete objects, and the
    matched / spurious / missed counts (missed: world discrete objects within `corridor_m` of the route not built)."""
    import shapely

    truth = [(o.id, np.asarray(o.center, float)) for o in world.objects if o.kind in DISCRETE_KINDS and o.center is not None]
    T = np.array([c for _, c in truth]).reshape(-1, 2)
    used: set[int] = set()
    errs = []
    spurious = 0
    for o in built.objects:
        if len(T) == 0:
            spurious += 1
            continue
        d = np.linalg.norm(T - (o.x, o.y), axis=1)
        d[list(used)] = np.inf
        j = int(np.argmin(d))
        if d[j] <= match_m:
            used.add(j)
            errs.append(float(d[j]))
        else:
            spurious += 1
    line = shapely.LineString(route)
    near = [j for j, (_, c) in enumerate(truth) if line.distance(shapely.Point(c)) <= corridor_m]
    missed = sum(1 for j in near if j not in used)
    return {"matched": len(errs), "spurious": spurious, "missed": missed,
            "error_mean_m": round(float(np.mean(errs)), 3) if errs else None,
            "error_max_m": round(float(np.max(errs)), 3) if errs else None}
