"""`sidewalk run --arch eddie`: the same mission on the same world, run by EDDIE's modules, with no blackboard.

The run uses the CODGER run's router, simulator, recorder and monitor processes and the same
`prepare_run` / `record_run` / `build_report`; what differs is the process plan and the observer:

- the mission compiles into trigger annotations (`eddie.missions`, along the MAP NAVIGATOR's route) in the
  mission service when it is submitted, which hands them to the map manager (started empty) before it accepts
  the mission — as for a mission submitted to a system started with `sidewalk up`; the launcher compiles it
  too, first, so a mission that does not compile is a launch error, and writes it as `annotated_map.geojson`
  into the run's out dir for the record (each step's route for the report);
- the processes are the controller, the navigator (told the start belief as `world` ← `local`), the
  map manager, the mission service (`eddie.mission_service.mission_service`: answers the CAPTAIN's mission
  submit / status / cancel keys and publishes the mission events, so `sidewalk submit` works
  unchanged) and, unless `--no-perception`, vision road following, landmark matching and obstacle stop;
- the observer follows the mission on the mission events stream (not a blackboard monitor), takes
  the estimated pose as navigator `world` ← `local` ∘ controller `local` pose, and records every
  trigger the map manager fires (sim time, believed position) for the report.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections import deque
import logging
import math
from pathlib import Path
from typing import Optional

from pydantic import ValidationError

from modules.vocabulary import MissionStatus
from sidewalk.observers import observer_plans
from sidewalk.eddie_observe import subscribe_eddie
from sidewalk.recorder import Recorder
from sidewalk.run_setup import LaunchError, RunConfig, RunSetup, road_method_flags, vision_flags
from sidewalk.run_record import FiredTrigger, RecordedPlan, StampedStatus
from sidewalk.supervisor import ProcessPlan
from sidewalk.system import SystemRun
from wire.keys import EddieKeys, MissionKeys
from wire.se2 import compose

log = logging.getLogger(__name__)

__all__ = ["EDDIE_MODULES", "EDDIE_PERCEPTION_MODULES", "ANNOTATED_MAP_NAME", "EddieArchitecture", "eddie_plans", "EddieSystemRun",
           "PoseComposer", "compile_annotated_map", "route_plans"]

#: The annotated map's file name in a run's output directory (the mission compiled at launch, for the record).
ANNOTATED_MAP_NAME = "annotated_map.geojson"
#: The map manager's state file in a run's output directory.
MAP_MANAGER_STATE = "map_manager.state.json"

#: EDDIE's always-on modules in start order (the consumers before the producers).
EDDIE_MODULES = ("controller", "navigator", "map_manager", "mission_service")

#: The perception modules, started unless `--no-perception` (each sleeps until a trigger wakes it).
EDDIE_PERCEPTION_MODULES = ("obstacle_stop", "landmark_matching", "road_following")


def eddie_plans(cfg: RunConfig, setup: RunSetup, ns: str, endpoint: str,
                annotated_map: Optional[Path] = None) -> list[ProcessPlan]:
    """Return EDDIE's processes in start order: router, observers, simulator, then the EDDIE modules; no blackboard.

    The counterpart of CODGER's `build_plans`, from the same run config and setup. `annotated_map`: the
    mission service's compiled annotations to start with (None: every mission compiled as submitted).
    From `cfg`: `secure`, the `sidewalk security init` directory every process gets as --secure (each its
    own role); `actors`, objects not on the map the simulator places (issue 12); `max_speed` [m/s], EDDIE's
    counterpart of the PILOT's cap — the mission service's route speed and the controller's top speed;
    the road method and vision workers for road following (issues 13, 41); `obstacle_sensor`: `laser`
    (obstacle stop) or `fido` (`eddie.fido_stop`, run under obstacle stop's name, issue 41).
    """
    out, vehicle, seed, map_file = Path(cfg.out), setup.vehicle, cfg.seed, setup.map_file
    road_method = road_method_flags(cfg, setup) + vision_flags(cfg)
    cap = () if cfg.max_speed is None else ("--max-speed", str(cfg.max_speed))
    sec = () if cfg.secure is None else ("--secure", str(cfg.secure))  # issue 14
    zflags = ("--ns", ns, "--connect", endpoint, *sec)
    sx, sy, syaw = setup.start_belief
    truth = setup.start_truth
    sim_start = () if truth is None else (f"--start={truth[0]},{truth[1]},{math.degrees(truth[2])}",)
    plans = [
        ProcessPlan("router", ("-m", "sidewalk", "up", "router", "--ns", ns, "--listen", endpoint, *sec)),
        *observer_plans(out, zflags, record=cfg.record, monitor_port=cfg.monitor_port, arch="eddie"),
        ProcessPlan("sim", ("-m", "sidewalk", "up", "sim", "--world", cfg.world, "--vehicle", vehicle, *sim_start,
                            "--rtf", str(cfg.rtf), "--seed", str(seed), "--watchdog", str(cfg.watchdog_s), *zflags,
                            *(("--actors", cfg.actors) if cfg.actors else ()))),
        ProcessPlan("controller", ("-m", "sidewalk", "up", "controller", "--vehicle", vehicle, *cap, *zflags)),
        ProcessPlan("navigator", ("-m", "sidewalk", "up", "navigator", f"--start-pose={sx},{sy},{syaw}", *zflags)),
    ]
    # the map manager starts empty: the mission service compiles each submitted mission and hands it the annotations;
    # its state file in the run's out dir, which a manager restarted by a fault or the supervisor takes up
    plans.append(ProcessPlan("map_manager", ("-m", "sidewalk", "up", "map_manager", "--state", str(Path(out) / MAP_MANAGER_STATE),
                                             *zflags)))
    if cfg.perception:
        # obstacle stop sleeps until the route's `start_obstacles` triggers switch it on (issue 12)
        up = {"obstacle_stop": "fido_stop"} if cfg.obstacle_sensor == "fido" else {}
        plans += [ProcessPlan(name, ("-m", "sidewalk", "up", up.get(name, name), "--vehicle", vehicle, "--map", str(map_file),
                                     f"--start-pose={sx},{sy},{syaw}", "--seed", str(seed), *zflags,
                                     *(("--asleep",) if name == "obstacle_stop" else ()),
                                     *(road_method if name == "road_following" else ())))
                  for name in EDDIE_PERCEPTION_MODULES]
    plans.append(ProcessPlan("mission_service", (
        "-m", "sidewalk", "up", "mission_service", "--map", str(map_file),
        *(() if annotated_map is None else ("--annotated-map", str(annotated_map))), "--vehicle", vehicle, f"--start-pose={sx},{sy},{syaw}", "--perception", "on" if cfg.perception else "off",
        *(() if cfg.max_speed is None else ("--speed", str(cfg.max_speed))), *zflags)))
    return plans


class PoseComposer:
    """Keep the navigator's `world` ← `local` and the controller's `local` pose; answer the `world` pose.

    The estimate of an EDDIE run is what its modules believe: world←local (navigator) ∘ the
    dead-reckoned local pose (controller). In real time a sample is the newest of each. In lock-step
    (`lockstep=True`) it is the belief at the truth sample's own stamp t: the controller's pose of t
    (waited for: the observer is outside the barrier and may hear the truth first) and the newest
    world←local of a fix before t, so two runs of one seed sample the same estimate.
    """

    def __init__(self, *, lockstep: bool = False, keep: int = 400) -> None:
        self.lockstep = lockstep
        self.world_from_local: tuple[float, float, float] | None = None
        self.local: tuple[float, float, float] | None = None
        self.local_stamp: float | None = None
        self._locals: deque[tuple[float, tuple[float, float, float]]] = deque(maxlen=keep)
        self._transforms: deque[tuple[float, tuple[float, float, float]]] = deque(maxlen=keep)
        self._heard = asyncio.Event()

    def set_world_from_local(self, pose: tuple[float, float, float], stamp: float = 0.0) -> None:
        """Take a new navigator transform (x [m], y [m], yaw [rad]) as of `stamp` [s] sim."""
        self.world_from_local = pose
        self._transforms.append((stamp, pose))

    def set_local(self, stamp: float, pose: tuple[float, float, float]) -> None:
        """Take a new controller pose in `local` at `stamp` [s] sim."""
        self.local_stamp, self.local = stamp, pose
        self._locals.append((stamp, pose))
        self._heard.set()

    def world(self) -> tuple[float, float, float] | None:
        """Return the believed pose in `world` (None before both parts were heard)."""
        if self.world_from_local is None or self.local is None:
            return None
        x, y, yaw = compose(self.world_from_local, self.local)
        return float(x), float(y), float(yaw)

    async def at(self, stamp: float, *, wait_s: float = 2.0) -> tuple[float, float, float] | None:
        """Return the believed pose (the recorder's estimate source): the newest, or in lock-step the one of `stamp` [s] sim."""
        if not self.lockstep:
            return self.world()
        loop = asyncio.get_running_loop()
        end = loop.time() + wait_s
        while self.local_stamp is None or self.local_stamp < stamp:
            self._heard.clear()
            left = end - loop.time()
            if left <= 0:
                break
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(self._heard.wait(), left)
        local = next((p for t, p in reversed(self._locals) if t <= stamp), None)
        w = next((p for t, p in reversed(self._transforms) if t < stamp or t == 0.0), None)  # 0: the start, no fix
        if local is None or w is None:
            return None
        x, y, yaw = compose(w, local)
        return float(x), float(y), float(yaw)


class EddieSystemRun(SystemRun):
    """Start EDDIE's processes, then watch the run from outside like an operator — without a blackboard.

    It keeps what `record_run` reads (`submitted`, `statuses`, `routes`, `rest`, `bb_stats` stays
    None, `recorder`) and `triggers`, every trigger fired; statuses come from the mission events stream.
    """

    def __init__(self, plans: list[ProcessPlan], *, ns: str, endpoint: str, log_dir: Path,
                 annotated_map: Optional[Path] = None, secure: Path | None = None, lockstep: bool = False) -> None:
        super().__init__(plans, ns=ns, endpoint=endpoint, log_dir=log_dir, secure=secure, lockstep=lockstep)
        self.annotated_map = annotated_map
        self.pose = PoseComposer(lockstep=lockstep)
        self.triggers: list[FiredTrigger] = []
        self._status_q: asyncio.Queue[MissionStatus] = asyncio.Queue()

    async def _recorder(self) -> Recorder:
        """Return the run's recorder, its estimate what the EDDIE modules believe (`PoseComposer`); no blackboard."""
        return Recorder(self.link, None, self.ns, estimator=self.pose.at, lockstep=self.lockstep)

    async def _follow(self) -> None:
        """Follow the mission events stream, the pose parts and the triggers fired."""
        self.link.subscribe(MissionKeys(self.ns).events, self._on_status)
        subscribe_eddie(self.link, EddieKeys(self.ns), self.pose, self.triggers)

    def _on_status(self, _key: str, payload: bytes) -> None:
        try:
            st = MissionStatus.model_validate_json(payload)
        except ValidationError:
            return
        wall, sim = self.stamps()
        self.statuses.setdefault(st.mission_id, []).append(StampedStatus(wall_s=wall, sim_s=sim, status=st))
        self._status_q.put_nowait(st)

    async def next_status(self, mission_id: str, timeout: float) -> Optional[MissionStatus]:
        """Return the next status of `mission_id` published within `timeout` wall [s], else None."""
        loop = asyncio.get_running_loop()
        end = loop.time() + timeout
        while (left := end - loop.time()) > 0:
            try:
                st = await asyncio.wait_for(self._status_q.get(), left)
            except (asyncio.TimeoutError, TimeoutError):
                return None
            if st.mission_id == mission_id:
                return st
        return None

    async def finish(self, mission_id: str) -> None:
        """Wait until the vehicle has come to rest (call once the mission ended, before `close()`); take the route from the annotated map."""
        await self._settle(mission_id)
        at = self.submitted.get(mission_id, (0.0, 0.0))[1]
        self.routes[mission_id] = [] if self.annotated_map is None else route_plans(self.annotated_map, stamp=at)


def route_plans(annotated_map: Path, *, stamp: float) -> list[RecordedPlan]:
    """Return each step's route (`world`) as the mission compiler laid it into the annotated map's `route` annotations.

    EDDIE plans no route at run time: the route is the one compiled into the map, so it is each
    step's one plan (revision 0, stamped `stamp` [s] sim) — what cross-track error is measured against.
    """
    from eddie.annotated_map.geojson_file import load_annotations
    from eddie.messages.map_manager import RouteSegment, open_trigger_data

    by_step: dict[int, list[tuple[int, tuple[tuple[float, float], ...]]]] = {}
    for a in load_annotations(annotated_map):
        if a.type != "route":
            continue
        seg = open_trigger_data(a.data)
        if isinstance(seg, RouteSegment):
            by_step.setdefault(seg.step_index, []).append((seg.index, tuple((float(x), float(y)) for x, y in seg.points)))
    plans = []
    for step, segs in sorted(by_step.items()):
        line: list[tuple[float, float]] = []
        for _i, pts in sorted(segs):
            line.extend(p for p in pts if not line or math.dist(line[-1], p) > 1e-6)
        plans.append(RecordedPlan(step_index=step, revision=0, stamp=stamp, polyline=tuple(line)))
    return plans


def compile_annotated_map(setup: RunSetup, out: Path) -> Path:
    """Compile the run's mission into trigger annotations along the MAP NAVIGATOR's route; write and return the file.

    The compiler is `eddie.missions` (it plans the route on the map the robot gets, `setup.map_file`,
    from the mission's or the map's start); the file is `out`/annotated_map.geojson, which a person can open in QGIS.
    """
    from eddie.annotated_map.geojson_file import save_annotations
    from eddie.missions import MissionCompileError, compile_mission_files

    path = Path(out) / ANNOTATED_MAP_NAME
    try:
        compiled = compile_mission_files(setup.mission_file, setup.map_file, vehicle=setup.vehicle)
    except MissionCompileError as exc:
        raise LaunchError(f"--arch eddie: {setup.mission_file}: {exc}") from None
    save_annotations(path, compiled.annotations, name=f"{compiled.mission} on {compiled.map_name}")
    return path


class EddieArchitecture:
    """EDDIE behind the seam: the mission compiled for the record before start, `eddie_plans`, `EddieSystemRun` observing."""

    name = "eddie"

    def prepare(self, setup: RunSetup, out: Path) -> Path:
        """Compile the mission into the annotated map kept in `out` (a mission that does not compile: LaunchError); return its path."""
        return compile_annotated_map(setup, out)

    def plans(self, cfg: RunConfig, setup: RunSetup, ns: str, endpoint: str, prepared: Path) -> list[ProcessPlan]:
        """Return EDDIE's processes in start order (`eddie_plans`)."""
        return eddie_plans(cfg, setup, ns, endpoint, annotated_map=prepared)

    def system(self, plans: list[ProcessPlan], *, ns: str, endpoint: str, log_dir: Path, prepared: Path, secure: Path | None,
               lockstep: bool) -> EddieSystemRun:
        """Return the observer of the run: `EddieSystemRun` (no blackboard; the route from the annotated map)."""
        return EddieSystemRun(plans, ns=ns, endpoint=endpoint, log_dir=log_dir, annotated_map=prepared, secure=secure,
                              lockstep=lockstep)
