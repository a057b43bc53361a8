"""`sidewalk perception …`: evaluate PERCEPTION against the simulator's ground truth; run the process.

This file is the composition root for perception evaluation: it captures frames with `vehicle_sim`
(pure, no network), turns them into `ColoredRangeImage`s on the laser grid, and hands them to the pure
`sidewalk.perception_eval`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Iterator

import numpy as np
import typer

from sidewalk.json_out import dumps

__all__ = ["perception_app", "FrameSource"]

perception_app = typer.Typer(help="PERCEPTION: colored-range segmentation, object finding, position fixes.", no_args_is_help=True)


@dataclass
class FrameSource:
    """Capture registered colored-range frames with ground truth from a world, at chosen poses."""

    world_name: str
    vehicle: str = "terregator"
    seed: int = 0
    use_map: bool = True  # predicted objects from the map file (False: from the world, a perfect map)

    def __post_init__(self) -> None:
        from vehicle_sim.scene import Scene
        from vehicle_sim.sensors import CaptureRequest, LaserConfig, extrinsics_for
        from vehicle_sim.worldfile import KINDS, load_world, world_path

        from modules.map_navigator.mapdata import map_object
        from modules.perception.monitor import ResolutionTable
        from sidewalk.robot_map import map_beside

        self.kinds = tuple(KINDS)
        path = Path(self.world_name) if self.world_name.endswith(".geojson") else world_path(self.world_name)
        self.world = load_world(path)
        # the map beside the world (never the world, unless a perfect map is asked for)
        self.map = load_world(map_beside(path), kind="map") if self.use_map else self.world
        self.scene = Scene(self.world, seed=self.seed)
        self.request = CaptureRequest()
        laser = LaserConfig()
        self.table = ResolutionTable(sensor_geometry(self.vehicle), max_distance=laser.ambiguity)
        self.map_objects = tuple(map_object(o) for o in self.map.objects)

    def capture(self, pose: tuple[float, float, float], stamp: float, rng: np.random.Generator):
        """Return (ColoredRangeImage, (H, W) truth class labels (-1 = none/sky), capture seconds) at a true pose."""
        from vehicle_sim.sensors import capture

        from modules.perception.sensor_frame import SensorFrame, colored_range_image

        t0 = time.perf_counter()
        res = capture(self.scene, pose, stamp, self.request, vehicle=self.vehicle, rng=rng)
        dt = time.perf_counter() - t0
        frame = SensorFrame.from_fields(res)
        img = colored_range_image(frame)
        labels = res.laser_labels.astype(np.int64)
        labels[(labels == self.kinds.index("sky")) | (labels == self.kinds.index("none"))] = -1
        self.last_frame = frame
        return img, labels, dt


def sensor_geometry(vehicle: str):
    """Return the laser geometry of a vehicle for the monitor's resolution table."""
    from vehicle_sim.sensors import LaserConfig, extrinsics_for

    from modules.perception.monitor import SensorGeometry

    laser = LaserConfig()
    lp = extrinsics_for(vehicle).laser_position
    return SensorGeometry(
        height=float(lp[2]), pitch_down=math.radians(-laser.tilt_deg), hfov=math.radians(laser.hfov_deg),
        vfov=math.radians(laser.vfov_deg), rows=laser.rows, cols=laser.cols, range_step=laser.range_step,
        x_offset=float(lp[0]),
    )


def _mission_routes(src: FrameSource) -> list[np.ndarray]:
    """Return the legs (world frame, direction of travel) of the shipped missions written for this world."""
    from modules.captain.missionfile import MissionFileError, load_mission
    from modules.map_navigator.mapdata import MapData
    from modules.map_navigator.route import RouteError, RouteOptions, select_route
    from vehicle_sim.worldfile import WORLDS_DIR

    legs: list[np.ndarray] = []
    m = MapData(src.map)
    for path in sorted(WORLDS_DIR.glob("*.yaml")):
        try:
            mission = load_mission(path)
        except MissionFileError:
            continue
        if mission.world not in (None, src.world.name) or src.map.start is None:
            continue
        start = (src.map.start.x, src.map.start.y)
        opts = RouteOptions(vehicle=mission.vehicle or src.vehicle)
        for step in mission.steps:
            try:
                route = select_route(m, start, step.destination, step.constraints, opts)
            except RouteError:
                break
            legs += [np.asarray(leg.coords, dtype=np.float64) for leg in route.legs if leg.length > 1.0]
            start = route.goal_xy
    return legs


def _route_edges(src: FrameSource) -> tuple[list[tuple[np.ndarray, bool]], str]:
    """Return the polylines to sample (world frame), whether each leads onto a slope or stairs, and their source.

    The shipped missions' routes (worlds/*.yaml written for this world) when there are any; otherwise
    every path-graph edge in both directions.
    """
    w = src.world
    three_d = [e for e in w.edges if e.mode in ("go-through-slope", "climb-stairs")]
    nodes_3d = np.array([(w.node(n).x, w.node(n).y) for e in three_d for n in (e.from_node, e.to_node)]).reshape(-1, 2)

    def near_3d(p: np.ndarray) -> bool:
        if len(nodes_3d) == 0:
            return False
        d = np.linalg.norm(nodes_3d[None, :, :] - p[:, None, :], axis=-1)
        return bool(d.min() < 1.0)

    legs = _mission_routes(src)
    if legs:
        return [(p, near_3d(p)) for p in legs], "missions"
    out = []
    for e in w.edges:
        for p in (e.points, e.points[::-1]):
            out.append((p, near_3d(p)))
    return out, "path graph"


def _sample_pose(poly: np.ndarray, rng: np.random.Generator, lateral: float = 0.4) -> tuple[float, float, float]:
    seg = np.diff(poly, axis=0)
    ln = np.linalg.norm(seg, axis=1)
    s = rng.uniform(0, ln.sum())
    i = int(min(np.searchsorted(np.cumsum(ln), s), len(seg) - 1))
    t = (s - (np.cumsum(ln)[i] - ln[i])) / max(ln[i], 1e-9)
    xy = poly[i] + t * seg[i]
    yaw = math.atan2(seg[i, 1], seg[i, 0])
    off = rng.uniform(-lateral, lateral)
    return (float(xy[0] - off * math.sin(yaw)), float(xy[1] + off * math.cos(yaw)), float(yaw + rng.normal(0, math.radians(4))))


def objects_in_view(src: FrameSource, pose: tuple[float, float, float], reach: float = 24.0):
    """Return the map objects whose footprint meets the sensor's reach ahead of the pose (what a driving unit carries)."""
    from shapely.geometry import Point, Polygon

    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    fan = [(0.0, -1.0), (reach, -reach * 0.9), (reach, reach * 0.9), (0.0, 1.0)]
    poly = Polygon([(x + c * a - s * b, y + s * a + c * b) for a, b in fan])
    out = []
    for o in src.map_objects:
        g = Polygon(o.polygon) if o.polygon is not None else Point(o.center).buffer(o.radius or 0.1)
        if g.intersects(poly):
            out.append(o)
    return tuple(out)


def eval_frames(src: FrameSource, frames: int, rng: np.random.Generator, pose_error: tuple[float, float] = (0.5, 2.0)) -> Iterator:
    """Yield `EvalFrame`s: half on approaches to the slope and stairs, half anywhere on the routes."""
    from sidewalk.perception_eval import EvalFrame

    routes, src.routes_from = _route_edges(src)
    focus = [p for p, f in routes if f] or [p for p, _ in routes]
    weights = np.array([np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p, _ in routes])
    for k in range(frames):
        if k % 2 == 0:
            poly = focus[int(rng.integers(len(focus)))]
        else:
            poly = routes[int(rng.choice(len(routes), p=weights / weights.sum()))][0]
        truth = _sample_pose(poly, rng)
        img, labels, dt = src.capture(truth, stamp=float(k), rng=rng)
        ang = rng.uniform(0, 2 * math.pi)
        d = abs(rng.normal(0, pose_error[0]))
        prior = (truth[0] + d * math.cos(ang), truth[1] + d * math.sin(ang), truth[2] + math.radians(rng.normal(0, pose_error[1])))
        yield EvalFrame(img, labels, src.kinds, truth, prior, objects_in_view(src, prior), dt, src.last_frame)


@perception_app.command("eval")
def eval_cmd(
    world: Annotated[str, typer.Option(help="World name (worlds/<name>.world.geojson) or file")] = "campus",
    frames: Annotated[int, typer.Option(min=1, help="Frames to capture")] = 60,
    seed: Annotated[int, typer.Option(help="Seed for poses, sensor noise and pose errors")] = 0,
    vehicle: Annotated[str, typer.Option(help="terregator or navlab (sensor mounting)")] = "terregator",
    pose_error: Annotated[str, typer.Option(help="Prior pose error as M,DEG (std) for the position fixes")] = "0.5,2",
    perfect_map: Annotated[bool, typer.Option("--perfect-map", help="Predict objects from the world instead of the map file")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object")] = False,
    laser: Annotated[bool, typer.Option("--laser", help="Score the laser libraries instead: obstacles, landmarks, time per frame")] = False,
    actors: Annotated[str, typer.Option("--actors", help="With --laser or --fido: objects not on the map (file or preset; default <world>-eval when it exists)")] = "",
    fido: Annotated[bool, typer.Option("--fido", help="Score FIDO's stereo beside OpenCV's SGBM and the laser: depth, obstacles, motion, time per step")] = False,
    straight_leg: Annotated[float, typer.Option("--straight-leg", min=0.0, help="With --fido: the straight leg [m] driven for the motion figure (0: none)")] = 50.0,
    vision_workers: Annotated[int, typer.Option("--vision-workers", min=1, max=64, help="Processes the per-pixel stages run on in stripes (1: this process alone)")] = 1,
) -> None:
    """Score colour, range and colored-range segmentation, position fixes and cycle time against truth."""
    if laser and fido:
        raise typer.BadParameter("--laser and --fido: choose one")
    if laser:
        _laser_eval(world, frames, seed, vehicle, actors, as_json)
        return
    if fido:
        _fido_eval(world, frames, seed, vehicle, actors, straight_leg, as_json)
        return
    from sidewalk.perception_eval import evaluate
    from modules.perception.pipeline import PerceptionPipeline

    try:
        pe = tuple(float(v) for v in pose_error.split(","))
        if len(pe) != 2:
            raise ValueError
    except ValueError:
        raise typer.BadParameter(f"--pose-error: expected M,DEG (two numbers), got {pose_error!r}") from None
    try:
        src = FrameSource(world, vehicle=vehicle, seed=seed, use_map=not perfect_map)
    except (FileNotFoundError, ValueError) as exc:
        raise typer.BadParameter(f"--world {world!r}: {exc}") from None
    rng = np.random.default_rng(seed)
    from modules.parallel import VisionPool

    with VisionPool(vision_workers, warm=("modules.perception",)) as pool, np.errstate(all="ignore"):
        pipe = PerceptionPipeline(src.table, pool=pool)
        allowance = max(0.5, 2.0 * pe[0])  # what the PILOT would put in the driving unit for this prior
        report = evaluate(eval_frames(src, frames, rng, pe), pipe, error_allowance=allowance).as_dict()  # type: ignore[arg-type]
    report.update({"vision_workers": vision_workers, "frames_along": getattr(src, "routes_from", ""), "world": world, "vehicle": vehicle, "seed": seed, "map": "world" if perfect_map else "map", "pose_error": pose_error,
                   "error_allowance_m": allowance})
    if as_json:
        typer.echo(dumps(report, sort_keys=True))
        return
    from rich.console import Console
    from rich.table import Table

    con = Console()
    t = Table("class", *report["iou_focus"].keys(), title=f"IoU on slope/stairs frames ({report['focus_frames']} of {report['frames']})")
    for c in ("slope", "stairs", "grass", "sidewalk", "intersection"):
        t.add_row(c, *(f"{report['iou_focus'][m].get(c, float('nan')):.3f}" for m in report["iou_focus"]))
    t.add_row("mean{slope,stairs,grass}", *(f"{report['mean_iou_focus'][m]['mean_iou']:.3f}" for m in report["iou_focus"]))
    con.print(t)
    con.print({k: report[k] for k in ("position_fix", "cycle_ms_p50", "cycle_ms_p95", "capture_ms_p50")})


def _eval_source(world: str, vehicle: str, seed: int, actors: str):
    """Return an evaluation's frame source, its actors (the flag's, or the world's `<world>-eval` preset; added to the
    scene) with their name, and the routes to sample."""
    from vehicle_sim.actors import ACTOR_PRESETS, ActorError, load_actors

    try:
        src = FrameSource(world, vehicle=vehicle, seed=seed)
    except (FileNotFoundError, ValueError) as exc:
        raise typer.BadParameter(f"--world {world!r}: {exc}") from None
    spec = actors or (f"{src.world.name}-eval" if f"{src.world.name}-eval" in ACTOR_PRESETS else "")
    try:
        aset = load_actors(spec) if spec else None
    except ActorError as exc:
        raise typer.BadParameter(f"--actors: {exc}") from None
    if aset is not None:
        src.scene.add_actors(aset)
    routes, _ = _route_edges(src)
    return src, aset, spec, routes


#: FIDO's evaluation: steps per leg, metres per step, sim seconds per step and between legs' starts
_LEG_STEPS, _STEP_M, _STEP_S, _LEG_S = 10, 1.0, 2.0, 60.0


def _fido_eval(world: str, frames: int, seed: int, vehicle: str, actors: str, straight: float, as_json: bool) -> None:
    """Run `perception eval --fido`: legs of 1 m steps, half approaching an actor, half anywhere on the routes, then the straight leg."""
    from sidewalk.fido_eval import FidoEvaluation, approach_leg, segment_leg, straight_leg

    src, aset, spec, routes = _eval_source(world, vehicle, seed, actors)
    segments = [(p[i], p[i + 1]) for p, _ in routes for i in range(len(p) - 1) if np.linalg.norm(p[i + 1] - p[i]) > 2.0]
    if not segments:
        raise typer.BadParameter(f"--world {world!r}: no route piece longer than 2 m to drive along")
    rng = np.random.default_rng(seed)
    legs = []
    steps = 0
    while steps < frames:
        t0 = _LEG_S * len(legs)
        if aset is not None and len(aset) and len(legs) % 2 == 0:
            st = aset.states(t0)[int(rng.integers(len(aset)))]
            leg = approach_leg(segments, (st.x, st.y), min(_LEG_STEPS, frames - steps), _STEP_M, t0, _STEP_S, rng)
        else:
            leg = segment_leg(segments, min(_LEG_STEPS, frames - steps), _STEP_M, t0, _STEP_S, rng)
        legs.append(leg)
        steps += len(leg.poses)
    if straight > 0:
        leg = straight_leg(segments, straight, _STEP_M, _LEG_S * len(legs), _STEP_S, rng)
        if leg is None:
            raise typer.BadParameter(f"--straight-leg {straight:g}: no straight route piece of {straight + 2:g} m in {world!r}")
        legs.append(leg)
    ev = FidoEvaluation(scene=src.scene, world=src.world, actors=aset, vehicle=vehicle)
    for leg in legs:
        ev.run_leg(leg, rng)
    from vehicle_sim.sensors import StereoConfig

    cfg = StereoConfig()
    report = ev.as_dict()
    report.update({"world": world, "vehicle": vehicle, "seed": seed, "actors": spec, "legs": len(legs), "step_m": _STEP_M,
                   "straight_leg_m": straight, "stereo": {"size_px": cfg.size, "hfov_deg": cfg.hfov_deg, "baseline_m": cfg.baseline}})
    if as_json:
        typer.echo(dumps(report, sort_keys=True))
    else:
        from rich.console import Console

        Console().print(report)


def _laser_eval(world: str, frames: int, seed: int, vehicle: str, actors: str, as_json: bool) -> None:
    """Run `perception eval --laser`: half the frames approach an actor, half anywhere on the routes."""
    from sidewalk.laser_eval import LaserEvaluation, score_frame, truth_obstacles
    from vehicle_sim.sensors import CaptureRequest, capture

    src, aset, spec, routes = _eval_source(world, vehicle, seed, actors)
    weights = np.array([np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p, _ in routes])
    rng = np.random.default_rng(seed)
    ev = LaserEvaluation()
    req = CaptureRequest(camera=False, truth=True)
    for k in range(frames):
        stamp = float(k)
        if aset is not None and len(aset) and k % 2 == 0:  # approach an actor along the route direction nearest it
            st = aset.states(stamp)[int(rng.integers(len(aset)))]
            poly = min((p for p, _ in routes), key=lambda p: float(np.min(np.linalg.norm(p - (st.x, st.y), axis=1))))
            j = int(np.argmin(np.linalg.norm(poly - (st.x, st.y), axis=1)))
            a, b = poly[max(j - 1, 0)], poly[min(j + 1, len(poly) - 1)]
            yaw = math.atan2(b[1] - a[1], b[0] - a[0])
            back = rng.uniform(3.0, 15.0)
            lat = rng.uniform(-1.0, 1.0)
            pose = (st.x - back * math.cos(yaw) - lat * math.sin(yaw), st.y - back * math.sin(yaw) + lat * math.cos(yaw),
                    yaw + rng.normal(0, math.radians(4)))
        else:
            pose = _sample_pose(routes[int(rng.choice(len(routes), p=weights / weights.sum()))][0], rng)
        scene = src.scene.at_time(aset, stamp) if aset is not None else src.scene
        res = capture(scene, pose, stamp, req, vehicle=vehicle, rng=rng)
        score_frame(ev, res, truth_obstacles(src.world, aset, stamp), pose)
    report = ev.as_dict()
    report.update({"world": world, "vehicle": vehicle, "seed": seed, "actors": spec})
    if as_json:
        typer.echo(dumps(report, sort_keys=True))
    else:
        from rich.console import Console

        Console().print(report)


def _run_command() -> None:
    from wire.flags import with_network

    @perception_app.command("run")
    @with_network("peer", who="perception")
    def run_cmd(
        net,
        vehicle: Annotated[str, typer.Option(help="terregator or navlab (the first capture's calibration then wins)")] = "terregator",
        speed: Annotated[float, typer.Option(min=0.01, help="desired speed for the view/resolution table (m/s)")] = 1.0,
        max_wait: Annotated[float, typer.Option(min=0.01, help="longest wait for the image input position (s, sim time)")] = 6.0,
        name: Annotated[str, typer.Option(help="module name (liveliness, heartbeat)")] = "perception",
        vision_workers: Annotated[int, typer.Option("--vision-workers", min=1, max=64, help="processes the per-pixel stages run on in stripes (1: this process alone)")] = 1,
    ) -> None:
        """Run the PERCEPTION process: answer driving units from the blackboard with the simulator's sensors."""
        from pydantic import ValidationError

        from codger.perception.module import PerceptionConfig, PerceptionModule
        from runtime import run_module, setup_logging

        try:
            cfg = PerceptionConfig(vehicle=vehicle, speed=speed, max_wait_s=max_wait, vision_workers=vision_workers)
        except ValidationError as exc:
            raise typer.BadParameter("; ".join(f"--{e['loc'][0]}: {e['msg']}" for e in exc.errors())) from None
        setup_logging()

        async def body(rt) -> None:
            await PerceptionModule(rt, cfg).run()

        raise typer.Exit(run_module(name, body, net))


_run_command()
