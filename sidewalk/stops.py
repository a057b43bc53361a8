"""Stops for obstacles and clearance to the actors, measured from a run's true track (evaluation only)."""

from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

__all__ = ["StopSpan", "StopSummary", "stop_summary", "AHEAD_M", "BESIDE_M"]

#: A stop is for an actor when the actor's footprint comes within this far ahead of the vehicle's origin [m] …
AHEAD_M = 25.0
#: … and this far to either side of its heading line [m] (the lane and a margin).
BESIDE_M = 3.0


class StopSpan(BaseModel):
    """One stop on the way: when it began [s] (from submission when known, else sim time), how long [s], where (x, y) [m] `world`."""

    model_config = ConfigDict(frozen=True)

    at_s: float
    duration_s: float
    x: float
    y: float
    #: the actor standing ahead in the vehicle's way when it stopped (within `AHEAD_M` ahead, `BESIDE_M` aside), by truth
    actor: Optional[str] = None


class StopSummary(BaseModel):
    """How often the vehicle stopped on the way (not at the start or the end), for how long [s] sim, each stop
    (`spans`), and how close its footprint came to any actor [m] (None without actors)."""

    model_config = ConfigDict(frozen=True)

    stops: int
    stopped_s: float
    spans: tuple[StopSpan, ...] = ()
    #: the stops with an actor ahead in the way (stops for obstacles) and their time [s]
    obstacle_stops: int = 0
    obstacle_stopped_s: float = 0.0
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
    starts: list[int] = []  # the track row each stop begins at
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
                    starts.append(i)
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
        at_start = {k: j for j, k in enumerate(starts)}
        for k, (t, x, y, yaw) in enumerate(tr):
            aset.update(t, (x, y))
            pts = sim.footprint_world(VehicleState(x=x, y=y, yaw=yaw))
            for a, corners in aset.footprints(t):
                best = min(best, _clearance(pts, corners))
                if k in at_start:
                    c, s_ = math.cos(yaw), math.sin(yaw)
                    ahead = (corners[:, 0] - x) * c + (corners[:, 1] - y) * s_
                    beside = -(corners[:, 0] - x) * s_ + (corners[:, 1] - y) * c
                    if ahead.max() > 0.0 and ahead.min() < AHEAD_M and beside.min() < BESIDE_M and beside.max() > -BESIDE_M:
                        j = at_start[k]
                        if spans[j].actor is None:
                            spans[j] = spans[j].model_copy(update={"actor": a.id})
        clearance = round(best, 3) if math.isfinite(best) else None
    held = [sp for sp in spans if sp.actor is not None]
    return StopSummary(stops=stops, stopped_s=round(stopped, 3), spans=tuple(spans), obstacle_stops=len(held),
                       obstacle_stopped_s=round(sum(sp.duration_s for sp in held), 3), min_actor_clearance_m=clearance)
