"""`sidewalk roadfollow …`: the road followers (SCARF, YARF, ALVINN) — ALVINN's data set and training, evaluation.

This file is the composition root for road following: it renders camera frames with `vehicle_sim`
along the follow-road legs of the world's shipped missions (truth is allowed here, never in
`modules/`), trains ALVINN from those frames, and hands frames to the pure `sidewalk.roadfollow_eval`.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Annotated, Iterator, Optional

import numpy as np
import typer

from sidewalk.json_out import dumps

__all__ = ["roadfollow_app", "RouteFrames", "mission_legs", "lane_frame"]

roadfollow_app = typer.Typer(help="Road following as the Navlab did it: SCARF, YARF, ALVINN (data set, training, evaluation).",
                             no_args_is_help=True)

#: Each method's world and lane (seed: SCARF on unmarked roads, YARF on marked ones, ALVINN trained per road).
DEFAULT_WORLD = {"scarf": "north_hills", "yarf": "schenley", "alvinn": "north_hills"}
#: Where the vehicle drives relative to the route centre line [m] (+ left): the right lane on marked roads.
LANE_OFFSET = {"north_hills": 0.0, "schenley": -1.75}
_TRIM_M = 12.0  # keep frames this far from intersections (the seed switches to dead reckoning there)


def mission_legs(world, trim_m: float = _TRIM_M) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Return the follow-road legs of the world's shipped missions (world polylines, direction of travel), trimmed
    clear of intersections, and for each the route's whole centre line it lies on."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from modules.map_navigator.mapdata import MapData
    from modules.map_navigator.route import RouteError, RouteOptions, select_route
    from vehicle_sim.worldfile import WORLDS_DIR

    legs: list[np.ndarray] = []
    centres: list[np.ndarray] = []
    m = MapData(world)
    for path in sorted(WORLDS_DIR.glob("*.yaml")):
        try:
            mission = load_mission(path)
        except MissionFileError:
            continue
        if mission.world != world.name or world.start is None:
            continue
        start = (world.start.x, world.start.y)
        for step in mission.steps:
            try:
                route = select_route(m, start, step.destination, step.constraints, RouteOptions(vehicle=mission.vehicle or "navlab"))
            except RouteError:
                break
            centre = _extended(np.asarray(route.polyline(), float))
            for leg in route.legs:
                if leg.mode != "follow-road":
                    continue
                p = np.asarray(leg.coords, float)
                cut = _trim(p, trim_m if _is_intersection(world, leg.from_node) else 0.0,
                            trim_m if _is_intersection(world, leg.to_node) else 0.0)
                if cut is not None:
                    legs.append(cut)
                    centres.append(centre)
            start = route.goal_xy
    return legs, centres


def _extended(p: np.ndarray, metres: float = 30.0) -> np.ndarray:
    """Return the polyline with its end segments carried on straight `metres` [m] (truth just before the start)."""
    a = p[0] - (p[1] - p[0]) / np.linalg.norm(p[1] - p[0]) * metres
    b = p[-1] + (p[-1] - p[-2]) / np.linalg.norm(p[-1] - p[-2]) * metres
    return np.vstack([a, p, b])


def _is_intersection(world, node_id: str | None) -> bool:
    return node_id is not None and any(n.id == node_id and n.node_kind == "intersection" for n in world.nodes)


def _trim(p: np.ndarray, head: float, tail: float) -> np.ndarray | None:
    """Return the polyline without its first `head` and last `tail` metres (None if nothing is left)."""
    import shapely
    from shapely.ops import substring

    line = shapely.LineString(p)
    if line.length - head - tail < 5.0:
        return None
    return np.asarray(substring(line, head, line.length - tail).coords, float)


class RouteFrames:
    """Render camera frames along a world's mission legs at planned poses (the simulator's camera, Navlab mount)."""

    def __init__(self, world_name: str, *, seed: int = 0, width: int = 320, height: int = 240) -> None:
        from vehicle_sim.scene import Scene
        from vehicle_sim.sensors import CaptureRequest
        from vehicle_sim.worldfile import load_world, world_path

        path = Path(world_name) if world_name.endswith(".geojson") else world_path(world_name)
        self.world = load_world(path)
        self.scene = Scene(self.world, seed=seed)
        self.request = CaptureRequest(laser=False, camera=True, camera_width=width, camera_height=height)
        self.legs, self.centres = mission_legs(self.world)
        if not self.legs:
            raise ValueError(f"world {self.world.name!r} has no shipped mission with a follow-road leg (worlds/*.yaml)")
        import shapely

        roads = [shapely.Polygon(o.polygon) for o in self.world.objects if o.kind in ("road", "intersection") and o.polygon is not None]
        self.roads = shapely.union_all(roads) if roads else shapely.Polygon()
        shapely.prepare(self.roads)

    def road_shadow(self, pose, near_m: float = 5.0, far_m: float = 20.0, step_m: float = 0.5) -> float | None:
        """Return the share (0–1) of the road ground `near_m`–`far_m` [m] ahead of `pose` that lies in shadow (truth); None: no road there."""
        import shapely

        xs, ys = np.meshgrid(np.arange(near_m, far_m, step_m), np.arange(-far_m / 2.0, far_m / 2.0, step_m))
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        wx, wy = pose.x + c * xs - s * ys, pose.y + s * xs + c * ys
        on = shapely.contains_xy(self.roads, wx, wy)
        if not on.any():
            return None
        return float(np.mean(self.scene.sunlit_at(wx[on], wy[on]) < 0.5))

    def capture(self, pose, rng: np.random.Generator):
        """Return the capture (camera image and calibration) at a `DrivePose`."""
        from vehicle_sim.sensors import capture

        return capture(self.scene, (pose.x, pose.y, pose.yaw), pose.stamp, self.request, vehicle="navlab", rng=rng)

    def frames(self, poses, rng: np.random.Generator) -> Iterator:
        """Yield (EvalFrame, capture) for each pose."""
        from sidewalk.roadfollow_eval import EvalFrame

        for p in poses:
            cap = self.capture(p, rng)
            yield EvalFrame(pose=p, image=cap.camera_image, centre_world=self.centres[p.leg], road_shadow=self.road_shadow(p)), cap


def _world_or_exit(world: str, seed: int, **kw) -> RouteFrames:
    from wire.mapfile import WorldFileError

    try:
        return RouteFrames(world, seed=seed, **kw)
    except (WorldFileError, ValueError, KeyError, FileNotFoundError) as exc:
        raise typer.BadParameter(f"--world {world!r}: {str(exc).splitlines()[0]}") from None


@roadfollow_app.command("eval")
def eval_cmd(
    method: Annotated[str, typer.Option(help="scarf | yarf | alvinn")],
    world: Annotated[str, typer.Option(help="World name or file (default: north_hills for scarf and alvinn, schenley for yarf)")] = "",
    frames: Annotated[int, typer.Option(min=1, help="Frames along the mission legs (at most; they end with the legs)")] = 400,
    step: Annotated[float, typer.Option(min=0.2, help="Distance between frames [m] (3 m: 15 km/h at 0.7 s per frame)")] = 3.0,
    seed: Annotated[int, typer.Option(help="Seed for the drive, sensor noise and odometry noise")] = 0,
    model: Annotated[str, typer.Option(help="ALVINN weights (.npz from `sidewalk roadfollow train`)")] = "",
    intersections: Annotated[bool, typer.Option("--intersections", help="SCARF: also search for branch roads")] = False,
    texture: Annotated[bool, typer.Option("--texture", help="SCARF: feed the texture operator's image (blue pyramid) to the classifier")] = False,
    colour_model: Annotated[str, typer.Option("--colour-model", help="SCARF: how the colour classes are made: nearest_mean (default) or isodata (the paper's generator)")] = "nearest_mean",
    vision_workers: Annotated[int, typer.Option("--vision-workers", min=1, max=64, help="SCARF: processes its per-pixel stages run on in row stripes (1: this process alone)")] = 1,
    bootstrap: Annotated[bool, typer.Option("--bootstrap", help="YARF: lock-on from no prior (the vanishing-point Hough): --starts runs of --start-frames frames, each off its lane by up to ±2 m and ±10°")] = False,
    starts: Annotated[int, typer.Option(min=1, help="With --bootstrap: how many starts")] = 40,
    start_frames: Annotated[int, typer.Option("--start-frames", min=1, help="With --bootstrap: frames per start")] = 8,
    intersection: Annotated[bool, typer.Option("--intersection", help="YARF: drive through the route's first intersection (approach, branch, path into the lane): --runs runs")] = False,
    to: Annotated[str, typer.Option("--to", help="With --intersection: the place the route leads to (default: the world's mission destination; schenley: green turns left, clubhouse right)")] = "",
    runs: Annotated[int, typer.Option(min=1, help="With --intersection: runs, each with its own offset in the lane (±0.5 m) and noise")] = 5,
    lane_offset: Annotated[Optional[float], typer.Option("--lane-offset", help="Where the vehicle drives, left of the road centre [m] (negative: right; default: the world's lane); ALVINN is scored against that lane")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
) -> None:
    """Drive the mission legs of a world, run one road follower on the camera and score it against the true road."""
    from modules.road_following import Alvinn, AlvinnModelError, AlvinnNet, CameraGeometry, Scarf, ScarfConfig, Yarf
    from modules.road_following.spine_fit import Spine
    from sidewalk.roadfollow_eval import evaluate, plan_drive, summarise

    if method not in DEFAULT_WORLD:
        raise typer.BadParameter(f"--method: expected scarf, yarf or alvinn, got {method!r}")
    if intersection and method != "yarf":
        raise typer.BadParameter(f"--intersection: YARF's intersection navigation, not {method}")
    if bootstrap and method != "yarf":
        raise typer.BadParameter(f"--bootstrap: only YARF locates the road without a prior (the vanishing-point Hough), not {method}")
    if colour_model not in ("nearest_mean", "isodata"):
        raise typer.BadParameter(f"--colour-model: expected nearest_mean or isodata, got {colour_model!r}")
    world = world or DEFAULT_WORLD[method]
    net = None
    if method == "alvinn":
        if not model:
            raise typer.BadParameter("--model: ALVINN needs weights; make them with `sidewalk roadfollow dataset` and `train`")
        try:
            net = AlvinnNet.load(model)
        except AlvinnModelError as exc:
            raise typer.BadParameter(f"--model: {exc}") from None
    src = _world_or_exit(world, seed)
    rng = np.random.default_rng(seed)
    lane = LANE_OFFSET.get(src.world.name, 0.0) if lane_offset is None else lane_offset
    if bootstrap:
        _bootstrap_eval(src, rng, seed, lane, step, starts, start_frames, as_json)
        return
    if intersection:
        _intersection_eval(src, rng, seed, lane, to, runs, as_json)
        return
    poses = plan_drive(src.legs, frames, rng, step_m=step, lane_offset_m=lane)

    last: list = [None]  # the capture of the frame being scored: its camera model builds a fresh follower

    def make(fr):
        cam = CameraGeometry.from_capture(last[0])
        if method == "scarf":
            return Scarf(cam, ScarfConfig(intersections=intersections, texture=texture, colour_model=colour_model), pool=pool)
        if method == "yarf":
            return Yarf(cam, prior=Spine(offset=-lane))
        return Alvinn(cam, net)  # type: ignore[arg-type]

    def stream():
        for fr, cap in src.frames(poses, rng):
            last[0] = cap
            # ALVINN steers to the lane it was trained on: its road point is scored against that lane's centre
            yield lane_frame(fr, lane) if method == "alvinn" else fr

    from modules.parallel import VisionPool

    t0 = time.perf_counter()
    with VisionPool(vision_workers, warm=("modules.road_following",)) as pool:
        scores = list(evaluate(stream(), make, rng=rng))
    report = {"method": method, "world": src.world.name, "seed": seed, **summarise(scores),
              "wall_s": round(time.perf_counter() - t0, 2)}
    if method == "scarf":
        report.update(texture=texture, colour_model=colour_model, vision_workers=vision_workers)
    _echo_report(report, as_json)


def _echo_report(report: dict, as_json: bool, width: int = 24) -> None:
    """Print an evaluation's report: one JSON object, or one `name: value` line per figure."""
    if as_json:
        typer.echo(dumps(report, sort_keys=True))
        return
    for k, v in report.items():
        typer.echo(f"{k:>{width}}: {v}")


def _bootstrap_eval(src: RouteFrames, rng: np.random.Generator, seed: int, lane: float, step: float, starts: int, frames: int,
                    as_json: bool) -> None:
    """Run `roadfollow eval --method yarf --bootstrap`: lock-on from no prior at random starts off the lane."""
    from modules.road_following import CameraGeometry, Yarf
    from sidewalk.roadfollow_eval import evaluate_starts, plan_starts, summarise_starts

    runs = plan_starts(src.legs, starts, frames, rng, step_m=step, lane_offset_m=lane)
    if not runs:
        raise typer.BadParameter(f"--start-frames: no leg of {src.world.name!r} is {frames * step:g} m long")
    last: list = [None]

    def frames_of(run):
        for fr, cap in src.frames(run, rng):
            last[0] = cap
            yield fr

    t0 = time.perf_counter()
    locks = list(evaluate_starts((list(frames_of(r)) for r in runs), lambda fr: Yarf(CameraGeometry.from_capture(last[0]), prior=None), rng=rng))
    report = {"method": "yarf", "bootstrap": True, "world": src.world.name, "seed": seed, "start_frames": frames, "step_m": step,
              **summarise_starts(locks), "wall_s": round(time.perf_counter() - t0, 2)}
    _echo_report(report, as_json)


def _intersection_route(src: RouteFrames, to: str):
    """Return the route's centre line (N, 2) to place `to` and its first intersection: node (2,), polygon, index of the node's vertex."""
    import shapely

    from modules.captain.missionfile import MissionFileError, load_mission
    from modules.map_navigator.mapdata import MapData
    from modules.map_navigator.route import RouteError, RouteOptions, select_route
    from modules.vocabulary.mission import Destination, StepConstraints
    from vehicle_sim.worldfile import WORLDS_DIR

    w = src.world
    if not to:
        for path in sorted(WORLDS_DIR.glob("*.yaml")):
            try:
                mission = load_mission(path)
            except MissionFileError:
                continue
            if mission.world == w.name and mission.steps and mission.steps[0].destination.place:
                to = mission.steps[0].destination.place
                break
    try:
        route = select_route(MapData(w), (w.start.x, w.start.y), Destination(place=to), StepConstraints(), RouteOptions(vehicle="navlab"))
    except (RouteError, ValueError) as exc:
        raise typer.BadParameter(f"--to {to!r}: {str(exc).splitlines()[0]}") from None
    line = np.asarray(route.polyline(), float)
    nodes = [n for n in w.nodes if n.node_kind == "intersection"]
    for i, q in enumerate(line):
        for n in nodes:
            if math.hypot(q[0] - n.x, q[1] - n.y) < 0.5:
                poly = next((shapely.Polygon(o.polygon) for o in w.objects if o.kind == "intersection" and o.polygon is not None
                             and shapely.Polygon(o.polygon).contains(shapely.Point(n.x, n.y))), None)
                if poly is not None and 0 < i < len(line) - 1:
                    return line, np.array([n.x, n.y]), poly, i, to
    raise typer.BadParameter(f"--to {to!r}: the route of {w.name!r} crosses no intersection")


def _intersection_eval(src: RouteFrames, rng: np.random.Generator, seed: int, lane: float, to: str, runs: int, as_json: bool) -> None:
    """Run `roadfollow eval --method yarf --intersection`: YARF and its intersection navigation through the route's first intersection."""
    import shapely

    from modules.road_following import CameraGeometry, Spine, VehicleMotion, Yarf
    from modules.road_following.yarf_intersection import IntersectionConfig, IntersectionNavigator
    from wire.se2 import wrap_angle
    from sidewalk.roadfollow_eval import (DrivePose, EvalFrame, IntersectionTruth, _resample, score_intersection,
                                          summarise_intersection, to_vehicle)

    line, node, poly, k, to = _intersection_route(src, to)
    before, after = line[k] - line[k - 1], line[k + 1] - line[k]
    turn = "left" if before[0] * after[1] - before[1] * after[0] > 0 else "right"  # what the route says, as a mission would
    bdir = after / np.linalg.norm(after)
    centre = shapely.LineString(line)
    s_node = centre.project(shapely.Point(*node))
    cross = centre.intersection(poly.exterior)  # where the route enters and leaves the intersection: enters first
    s_edge = min(centre.project(p) for p in getattr(cross, "geoms", [cross]))
    lane_after = node + bdir * 10.0 + np.array([-bdir[1], bdir[0]]) * lane
    out = []
    t0 = time.perf_counter()
    for r in range(runs):
        extra = float(rng.uniform(-0.5, 0.5))
        path = np.asarray(centre.offset_curve(lane + extra, join_style="round").coords)
        if np.linalg.norm(path[0] - line[0]) > np.linalg.norm(path[-1] - line[0]):
            path = path[::-1]
        pts, s, hd = _resample(path, 2.0)
        along = np.array([centre.project(shapely.Point(*p)) for p in pts])
        keep = (along > s_edge - 110.0) & (along < s_node + 20.0)
        poses = [DrivePose(leg=0, x=float(p[0]), y=float(p[1]), yaw=float(h), stamp=float(si) / 4.2)
                 for p, si, h in zip(pts[keep], s[keep], hd[keep])]
        yarf = nav = prev = None
        scores = []
        for pose, a in zip(poses, along[keep]):
            cap = src.capture(pose, rng)
            if yarf is None:
                cam = CameraGeometry.from_capture(cap)
                yarf = Yarf(cam, prior=Spine(offset=-lane - extra))
                nav = IntersectionNavigator(cam, turn=turn, config=IntersectionConfig(lane_offset_m=lane))
            motion = None
            if prev is not None:
                d = to_vehicle(np.array([[pose.x, pose.y]]), prev)[0]
                motion = VehicleMotion(dx=float(d[0] + rng.normal(0.0, 0.01)), dy=float(d[1] + rng.normal(0.0, 0.01)),
                                       dyaw=float(wrap_angle(pose.yaw - prev.yaw) + rng.normal(0.0, math.radians(0.1))))
            prev = pose
            obs = yarf.observe(cap.camera_image, stamp=pose.stamp, motion=motion)
            view = nav.observe(cap.camera_image, motion, obs)
            truth = IntersectionTruth(distance_m=float(s_edge - a), branch_point=tuple(node), branch_dir=tuple(bdir), lane_point=tuple(lane_after))
            scores.append(score_intersection(view, pose, truth))
        out.append(scores)
    report = {"method": "yarf", "intersection": True, "world": src.world.name, "to": to, "turn": turn, "seed": seed,
              **summarise_intersection(out), "wall_s": round(time.perf_counter() - t0, 2)}
    _echo_report(report, as_json, width=36)


@roadfollow_app.command("dataset")
def dataset_cmd(
    world: Annotated[str, typer.Option(help="World name or file")] = "north_hills",
    out: Annotated[Path, typer.Option(help="Directory to write dataset.npz into")] = Path("runs/alvinn-data"),
    frames: Annotated[int, typer.Option(min=2, help="Images along the mission legs")] = 120,
    seed: Annotated[int, typer.Option(help="Seed for the drive and the sensor noise")] = 1,
    lane_offset: Annotated[Optional[float], typer.Option("--lane-offset", help="The lane driven, left of the road centre [m] (negative: right; default: the world's lane); ALVINN learns to steer to it")] = None,
) -> None:
    """Capture ALVINN's training images along the world's mission legs with the true lane centre (a person driving)."""
    from sidewalk.roadfollow_eval import plan_drive, to_vehicle

    src = _world_or_exit(world, seed, width=160, height=120)
    rng = np.random.default_rng(seed)
    total = sum(float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) for p in src.legs)
    lane = LANE_OFFSET.get(src.world.name, 0.0) if lane_offset is None else lane_offset
    poses = plan_drive(src.legs, frames, rng, step_m=total / frames, lane_offset_m=lane, weave_m=0.3, weave_period_m=57.0)
    images, centres = [], []
    cap = None
    for fr, cap in src.frames(poses, rng):
        c = to_vehicle(lane_frame(fr, lane).centre_world, fr.pose)
        images.append(fr.image)
        centres.append(_centre_ahead(c))
    assert cap is not None
    out.mkdir(parents=True, exist_ok=True)
    path = out / "dataset.npz"
    np.savez_compressed(path, images=np.stack(images), centres=np.stack(centres).astype(np.float32),
                        camera_K=np.asarray(cap.camera_K, float), T_vehicle_camera=np.asarray(cap.T_vehicle_camera, float),
                        world=np.array(src.world.name), seed=np.array(seed), lane_offset=np.array(lane))
    typer.echo(dumps({"dataset": str(path), "images": len(images), "world": src.world.name, "bytes": path.stat().st_size}))


def lane_frame(fr, lane_m: float):
    """Return the frame with its centre line moved `lane_m` [m] to the left (negative: right): the lane's centre."""
    import dataclasses

    import shapely

    if lane_m == 0.0:
        return fr
    moved = shapely.LineString(fr.centre_world).offset_curve(lane_m)
    return dataclasses.replace(fr, centre_world=np.asarray(moved.coords, float))


def _centre_ahead(c: np.ndarray, back_m: float = 5.0, ahead_m: float = 45.0, step: float = 1.0) -> np.ndarray:
    """Return the centre line (N, 2) in `vehicle` resampled every `step` [m] from `back_m` behind to `ahead_m` ahead of the vehicle."""
    import shapely

    line = shapely.LineString(c)
    s0 = line.project(shapely.Point(0.0, 0.0))
    ss = np.clip(np.arange(s0 - back_m, s0 + ahead_m + 1e-9, step), 0.0, line.length)
    return np.array([(q.x, q.y) for q in (line.interpolate(float(s)) for s in ss)])


@roadfollow_app.command("train")
def train_cmd(
    data: Annotated[Path, typer.Option(help="Directory with dataset.npz (from `sidewalk roadfollow dataset`)")],
    out: Annotated[Path, typer.Option(help="Weights file to write (.npz)")] = Path("runs/alvinn.npz"),
    views: Annotated[int, typer.Option(min=0, help="Shifted/rotated views per image")] = 12,
    hidden: Annotated[int, typer.Option(min=1, help="Hidden units")] = 5,
    epochs: Annotated[int, typer.Option(min=1, help="Training epochs")] = 80,
    seed: Annotated[int, typer.Option(help="Seed for the views and the weights")] = 0,
) -> None:
    """Train ALVINN's net on the data set, each image also shifted and rotated with the corrected steering."""
    from modules.road_following import AlvinnNet, AlvinnShape, CameraGeometry, decode_steering, steering_targets, training_views
    from wire.summary import percentile

    path = data / "dataset.npz" if data.is_dir() else data
    try:
        with np.load(path, allow_pickle=False) as f:
            images, centres = f["images"], f["centres"]
            cam = CameraGeometry(width=int(images.shape[2]), height=int(images.shape[1]), K=tuple(map(tuple, f["camera_K"])),
                                 T_vehicle_camera=tuple(map(tuple, f["T_vehicle_camera"])))
    except (OSError, KeyError, ValueError) as exc:
        raise typer.BadParameter(f"--data {str(path)!r}: not a road-following data set ({str(exc).splitlines()[0]})") from None
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    shape = AlvinnShape(hidden=hidden)
    xs, ks = [], []
    for img, c in zip(images, centres):
        x, k = training_views(img, cam, c, rng, views=views, lookahead_m=shape.lookahead_m, rows=shape.rows, cols=shape.cols)
        xs.append(x)
        ks.append(k)
    n_val = max(1, len(images) // 10)
    order = rng.permutation(len(images))
    val, tr = set(order[:n_val].tolist()), order[n_val:]
    x_tr = np.concatenate([xs[i] for i in tr])
    k_tr = np.concatenate([ks[i] for i in tr])
    x_val = np.concatenate([xs[i] for i in sorted(val)])
    k_val = np.concatenate([ks[i] for i in sorted(val)])
    net = AlvinnNet(shape, rng)
    losses = net.train(x_tr, steering_targets(k_tr, shape), rng, epochs=epochs)
    pred, _ = decode_steering(net.forward(x_val), shape)
    written = net.save(out)
    typer.echo(dumps({
        "model": str(written), "images": int(len(images)), "samples": int(len(x_tr)), "final_mse": round(losses[-1], 5),
        "val_curvature_err_p50": round(float(np.median(np.abs(pred - k_val))), 5),
        "val_curvature_err_p95": percentile(np.abs(pred - k_val), 95, digits=5),
        "train_s": round(time.perf_counter() - t0, 2),
    }))
