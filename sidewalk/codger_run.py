"""The CODGER architecture of `sidewalk run`: the blackboard node and CODGER's modules as processes.

Nothing is prepared before start; the observer is `SystemRun` (the estimate and the mission statuses
read from the blackboard). See `sidewalk.architecture` for the seam both architectures implement.
"""

from __future__ import annotations

import math
from pathlib import Path

from sidewalk.observers import observer_plans
from sidewalk.run_setup import RunConfig, RunSetup, road_method_flags, vision_flags
from sidewalk.supervisor import ProcessPlan
from sidewalk.system import SystemRun

__all__ = ["CODGER_MODULES", "CodgerArchitecture", "build_plans", "terrain_bounds"]

#: How far the terrain map reaches beyond the start and the off-road destinations [m].
TERRAIN_MARGIN_M = 30.0

#: Every module of the CODGER system in start order (the consumers before the producers).
CODGER_MODULES = ("helm", "perception", "pilot", "map_navigator", "captain")


def terrain_bounds(setup: RunSetup) -> tuple[float, float, float, float] | None:
    """Return the terrain map's extent (x0, y0, x1, y1) [m] `world` around the believed start and the mission's
    off-road destinations (what the robot is told, not the truth), or None for a mission with no off-road step."""
    points = [s.destination.xy for s in setup.mission.steps if s.destination.off_road and s.destination.xy is not None]
    if not points:
        return None
    xs = [setup.start_belief[0], *(p[0] for p in points)]
    ys = [setup.start_belief[1], *(p[1] for p in points)]
    m = TERRAIN_MARGIN_M
    return min(xs) - m, min(ys) - m, max(xs) + m, max(ys) + m


def build_plans(cfg: RunConfig, setup: RunSetup, ns: str, endpoint: str) -> list[ProcessPlan]:
    """Return the processes of a run in start order: router, node, simulator, then the modules."""
    secure = () if cfg.secure is None else ("--secure", str(cfg.secure))
    zflags = ("--ns", ns, "--connect", endpoint, *secure)
    out, vehicle = Path(cfg.out), setup.vehicle
    sx, sy, syaw = setup.start_belief
    sim_start = () if setup.start_truth is None else (
        f"--start={setup.start_truth[0]},{setup.start_truth[1]},{math.degrees(setup.start_truth[2])}",)
    plans = [
        ProcessPlan("router", ("-m", "sidewalk", "up", "router", "--ns", ns, "--listen", endpoint, *secure)),
        ProcessPlan("blackboard", ("-m", "sidewalk", "up", "blackboard", *zflags,
                                   "--db", str(out / "blackboard.db"), "--types", "modules.vocabulary")),
        ProcessPlan("sim", ("-m", "sidewalk", "up", "sim", "--world", cfg.world, "--vehicle", vehicle, *sim_start,
                            "--rtf", str(cfg.rtf), "--seed", str(cfg.seed), "--watchdog", str(cfg.watchdog_s), *zflags,
                            *(("--actors", cfg.actors) if cfg.actors else ()))),
        ProcessPlan("helm", ("-m", "sidewalk", "up", "helm", "--vehicle", vehicle, *zflags)),
    ]
    # ---- monitor and recording (issue 11): recorder and monitor start before the simulator ----
    plans[2:2] = observer_plans(out, zflags, record=cfg.record, monitor_port=cfg.monitor_port)
    if cfg.obstacles or (cfg.obstacles is None and (cfg.actors or setup.world.actors)):  # issue 12: actors of the flag or the world file
        sensor = "fido_obstacles" if cfg.obstacle_sensor == "fido" else "obstacles"  # issue 41
        plans.append(ProcessPlan(sensor, ("-m", "sidewalk", "up", sensor, "--map", str(setup.map_file), *zflags)))
    bounds = terrain_bounds(setup)
    if bounds is not None:  # issue 40: a mission across country maps the terrain from the laser
        plans.append(ProcessPlan("terrain", ("-m", "sidewalk", "up", "terrain", "--vehicle", vehicle,
                                             "--bounds=" + ",".join(f"{v:.1f}" for v in bounds), *zflags)))
    if cfg.perception:
        plans.append(ProcessPlan("perception", ("-m", "sidewalk", "up", "perception", "--vehicle", vehicle, *zflags,
                                                *road_method_flags(cfg), *vision_flags(cfg))))  # issues 13, 41
    plans += [
        ProcessPlan("pilot", ("-m", "sidewalk", "up", "pilot", "--vehicle", vehicle,
                              "--perception", "on" if cfg.perception else "off",
                              f"--start-pose={sx},{sy},{syaw}", "--seed", str(cfg.seed),
                              *(() if cfg.max_speed is None else ("--max-speed", str(cfg.max_speed))), *zflags)),
        ProcessPlan("map_navigator", ("-m", "sidewalk", "up", "map_navigator", "--map", str(setup.map_file),
                                      "--vehicle", vehicle, "--pilot-grace", str(cfg.pilot_grace_s), *zflags)),
        ProcessPlan("captain", ("-m", "sidewalk", "up", "captain", *zflags)),
    ]
    return plans


class CodgerArchitecture:
    """CODGER behind the seam: its plans (`build_plans`), nothing prepared, `SystemRun` observing through the blackboard."""

    name = "codger"

    def prepare(self, setup: RunSetup, out: Path) -> None:
        """Prepare nothing: CODGER's modules take the mission from the CAPTAIN."""
        return None

    def plans(self, cfg: RunConfig, setup: RunSetup, ns: str, endpoint: str, prepared: None) -> list[ProcessPlan]:
        """Return the run's processes in start order (`build_plans`)."""
        return build_plans(cfg, setup, ns, endpoint)

    def system(self, plans: list[ProcessPlan], *, ns: str, endpoint: str, log_dir: Path, prepared: None, secure: Path | None,
               lockstep: bool) -> SystemRun:
        """Return the observer of the run: `SystemRun`."""
        return SystemRun(plans, ns=ns, endpoint=endpoint, log_dir=log_dir, secure=secure, lockstep=lockstep)
