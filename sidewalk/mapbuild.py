"""Build a map of discrete objects by driving a route (seed: Navlab 1990 §1.2.4).

The vehicle is driven along a mission's route (the roads come from the map file: the path graph is
known, the objects are not); the driving is the simulator's business, as the seed's human driver
was. What the robot knows of where it is comes from dead reckoning only (the distance travelled,
by odometry, along the known lane of the route: "road-matched" dead reckoning; frames on bends
are skipped). Odometry's distance drifts (a scale error of ~1 % is 5 m over the AMV route), so the
distance is re-anchored at each turn of the route: where the odometry heading has turned half of a
sharp turn the vehicle is at the turn's middle on the map's lane (`turn_anchors`), and at the route's
end, where the drive stops `END_SHORT_M` before the destination (the seed's driver knew where the
mailbox was); between anchors the odometry distance is stretched to the map's. At every `step_m` of travel the laser is read; obstacles small enough to be trees,
posts, mailboxes become vehicle-frame observations; after the drive each frame is placed on the
lane at its anchored distance, the observations put in the `world` frame there, and the
`ObjectTracker` folds them in frame by frame (confidence up when seen, down when missed where it should appear,
maximum-likelihood positions, moving and spurious objects dropped). The built map is the map file's
ground (roads, lawns, buildings, path graph) with its discrete objects replaced by the built ones,
written as GeoJSON a later run takes with `sidewalk run --map FILE`. Truth (the world) is read here
only to drive the vehicle and to score the built map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict

from modules.perception.landmarks import LandmarkConfig, landmark_observations
from modules.perception.object_tracker import ObjectTracker, TrackedObject, TrackerConfig, WorldObservation
from modules.perception.obstacles import LaserScan, detect_obstacles
from wire.se2 import wrap_angle

__all__ = ["MapBuildReport", "BuiltMap", "DISCRETE_KINDS", "END_SHORT_M", "route_polyline", "build_map", "score_map",
           "write_map", "turn_anchors", "end_anchor", "anchored_distance"]

#: How far [m] before the route's end the mapping drive stops; the end anchors the odometry distance there.
END_SHORT_M = 1.0

#: Kinds of map objects that are discrete objects the laser maps (the rest is ground and buildings).
DISCRETE_KINDS = ("tree", "mailbox", "sign", "hydrant", "lamp_post", "bench", "rock")


class MapBuildReport(BaseModel):
    """The built map against truth: per-object error [m] (mean, max), matched / spurious / missed counts."""

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


def build_map(world, map_world, mission, *, actors=None, vehicle: str = "navlab", seed: int = 0, speed: float = 4.0,
              lane_offset: float = 1.5, step_m: float = 1.5, tracker: TrackerConfig = TrackerConfig(),
              landmarks: LandmarkConfig = LandmarkConfig()) -> BuiltMap:
    """Drive the mission's route in `world` and track the objects the laser finds (see the module docstring)."""
    from vehicle_sim.scene import Scene
    from vehicle_sim.sensors import CaptureRequest, capture
    from vehicle_sim.simulator import SimConfig, Simulator
    from wire.drive import DriveCommand

    path = route_polyline(map_world, mission)
    seg = np.diff(path, axis=0)
    nrm = np.stack([seg[:, 1], -seg[:, 0]], -1) / np.maximum(np.linalg.norm(seg, axis=1, keepdims=True), 1e-9)
    nrm = np.vstack([nrm, nrm[-1:]])
    lane = path + lane_offset * nrm  # keep right
    start = (float(lane[0, 0]), float(lane[0, 1]), math.atan2(seg[0, 1], seg[0, 0]))
    sim = Simulator(world, SimConfig(vehicle=vehicle, seed=seed, physics_hz=50.0, collisions_block=False), start=start,  # type: ignore[arg-type]
                    actors=actors)
    scene = Scene(world, seed=seed)
    if actors is not None and len(actors):
        scene.add_actors(actors)
    rng = np.random.default_rng([seed, 0x3A9])
    req = CaptureRequest(camera=False)
    kmax = 1.0 / 7.0 if vehicle == "navlab" else 2.0
    last_cap = -math.inf
    frames = 0
    seq = 0
    x0, y0, yaw0 = start  # world ← local: the robot knows where it started
    c0, s0 = math.cos(yaw0), math.sin(yaw0)
    lane_cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(lane, axis=0), axis=1))])
    heading: list[tuple[float, float]] = []  # (odometry distance [m], odometry heading [rad]) every step
    shots: list[tuple[float, list]] = []  # (odometry distance [m], vehicle-frame landmark observations)
    arrived = False
    while True:
        st = sim.state
        xy = np.array([st.x, st.y])
        target, s, total = _lookahead_point(lane, xy, max(4.0, 1.2 * st.v + 3.0))
        if total - s < END_SHORT_M:
            arrived = True
            break
        dx, dy = target - xy
        c, si = math.cos(st.yaw), math.sin(st.yaw)
        lx, ly = c * dx + si * dy, -si * dx + c * dy
        kappa = float(np.clip(2.0 * ly / max(lx * lx + ly * ly, 1e-6), -kmax, kmax))
        seq += 1
        sim.submit(DriveCommand(speed=min(speed, 1.0 + (total - s) * 0.5), curvature=kappa, duration=1.0, seq=seq))
        sim.advance(0.1)
        od = sim.odom
        heading.append((od.distance, yaw0 + od.yaw))
        if od.distance - last_cap >= step_m:
            last_cap = od.distance
            sc = scene.at_time(actors, sim.t) if actors is not None else scene
            cap = capture(sc, (sim.state.x, sim.state.y, sim.state.yaw), sim.t, req, vehicle=vehicle, rng=rng)
            shots.append((od.distance, landmark_observations(detect_obstacles(LaserScan.from_capture(cap)), landmarks)))
        if sim.t > 3600.0:
            break
    anchors = turn_anchors(lane, np.asarray(heading, np.float64).reshape(-1, 2))
    if arrived:
        # the stop at the destination anchors the last leg: without it the last turn's scale was extrapolated,
        # and a 110 m leg put the AMV's mailbox 1.55 m long (seed 0)
        anchors = end_anchor(anchors, float(sim.odom.distance), float(lane_cum[-1] - END_SHORT_M))
    tr = ObjectTracker(tracker)
    for dist, obs in shots:
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
    od = sim.odom
    est = np.array([x0 + c0 * od.x - s0 * od.y, y0 + s0 * od.x + c0 * od.y])
    return BuiltMap(objects=tr.mapped(), frames=frames, distance_m=float(od.distance), dropped_moving=tr.dropped_moving,
                    dropped_spurious=tr.dropped_spurious,
                    odometry_error_final_m=float(np.linalg.norm(est - (sim.state.x, sim.state.y))))


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


def end_anchor(anchors: np.ndarray, odometry_m: float, lane_m: float) -> np.ndarray:
    """Return `anchors` with (odometry distance [m], lane arc length [m]) at the drive's end added, if it lies past the last."""
    a = np.asarray(anchors, np.float64).reshape(-1, 2)
    if odometry_m > a[-1, 0] and lane_m > a[-1, 1]:
        return np.vstack([a, [[odometry_m, lane_m]]])
    return a


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
