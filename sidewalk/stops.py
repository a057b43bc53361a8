"""Stops for obstacles and clearance to the actors, measured from a run's true track (evaluation only)."""

from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

__all__ = ["StopSpan", "StopSummary", "stop_summary"]


class StopSpan(BaseModel):
    """One stop on the way: when it began [s] (from submission when known, else sim time), how long [s], where (x, y) [m] `world`."""

    model_config = ConfigDict(frozen=True)

    at_s: float
    duration_s: float
    x: float
    y: float


class StopSummary(BaseModel):
    """How often the vehicle stopped on the way (not at the start or the end), for how long [s] sim, each stop
    (`spans`), and how close its footprint came to any actor [m] (None without actors)."""

    model_config = ConfigDict(frozen=True)

    stops: int
    stopped_s: float
    spans: tuple[StopSpan, ...] = ()
    min_actor_clearance_m: Optional[float] = None


def stop_summary(truth: Sequence[Sequence[float]], *, actors: str | None, world_name: str, vehicle: str,
                 still: float = 0.05, min_stop_s: float = 1.0, t0: float = 0.0) -> StopSummary:
    """Return the stops (true speed below `still` [m/s] for at least `min_stop_s` [s], between first moving and
    the last move; times from sim time `t0` [s]) and the closest approach to the actors (the world file's and
    `actors`), replaying their scripts along the true track (t, x, y, yaw)."""
    tr = np.asarray(truth, float).reshape(-1, 4)
    if len(tr) < 3:
        return StopSummary(stops=0, stopped_s=0.0)
    dt = np.diff(tr[:, 0])
    v = np.hypot(np.diff(tr[:, 1]), np.diff(tr[:, 2])) / np.maximum(dt, 1e-9)
    moving = np.flatnonzero(v >= still)
    stops, stopped = 0, 0.0
    spans: list[StopSpan] = []
    if len(moving):
        i, last = int(moving[0]), int(moving[-1])
        while i < last:
            if v[i] < still:
                j = i
                while j < last and v[j] < still:
                    j += 1
                span = float(tr[j, 0] - tr[i, 0])
                if span >= min_stop_s:
                    stops += 1
                    stopped += span
                    spans.append(StopSpan(at_s=round(float(tr[i, 0]) - t0, 3), duration_s=round(span, 3),
                                          x=round(float(tr[i, 1]), 2), y=round(float(tr[i, 2]), 2)))
                i = j
            else:
                i += 1
    clearance = None
    from vehicle_sim.actors import ActorSet, load_actors
    from vehicle_sim.worldfile import load_world

    try:
        world = load_world(world_name)
        aset = world.actor_set() + (load_actors(actors) if actors else ActorSet())  # the world file's and the run's
    except (FileNotFoundError, ValueError):
        if actors:
            raise
        aset = ActorSet()  # a world given as a file the report cannot find by name: no actors of its own known
    if len(aset):
        from vehicle_sim.simulator import SimConfig, Simulator

        sim = Simulator(world, SimConfig(vehicle=vehicle))  # type: ignore[arg-type]
        from vehicle_sim.kinematics import VehicleState
        from vehicle_sim.simulator import _clearance

        best = math.inf
        for t, x, y, yaw in tr:
            aset.update(t, (x, y))
            pts = sim.footprint_world(VehicleState(x=x, y=y, yaw=yaw))
            for _, corners in aset.footprints(t):
                best = min(best, _clearance(pts, corners))
        clearance = round(best, 3) if math.isfinite(best) else None
    return StopSummary(stops=stops, stopped_s=round(stopped, 3), spans=tuple(spans), min_actor_clearance_m=clearance)
