"""A feasible corridor on the truth: the generator's proof that a generated world's goal can be reached.

A search over a lattice of the vehicle's own arcs: from a pose, 3 m straight ahead or along an arc
turning 22.5° (radius 7.6 m, wider than the Navlab's 7 m minimum), each move checked every 0.75 m
by the simulator's truth (`Simulator.blocked_at`: no solid touched, no tip-over, no high-centring,
no collision with the ground), a weighted A* towards the goal (the straight-line distance, twice:
a corridor is wanted, not the shortest one). Poses are kept per 1.5 m cell and 16 headings. Truth only: this lives beside the simulator, never in robot code.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from vehicle_sim.kinematics import integrate_arc
from vehicle_sim.simulator import SimConfig, Simulator
from vehicle_sim.worldfile import World

__all__ = ["find_corridor", "STEP_M", "TURN_RAD"]

#: Length of one lattice move [m] and the heading change of a turning move [rad].
STEP_M = 3.0
TURN_RAD = math.radians(22.5)
_CHECKS = 4  # poses checked per move
_CELL = 1.5  # [m]
_GREED = 2.0  # heuristic weight


def find_corridor(world: World, start: tuple[float, float, float], goal: tuple[float, float], *, vehicle: str = "navlab",
                  reach: float = 3.0, max_expansions: int = 20_000) -> np.ndarray | None:
    """Return a feasible track (K, 3) [m, m, rad] from `start` (x, y, yaw) to within `reach` [m] of `goal`, or None."""
    sim = Simulator(world, SimConfig(vehicle=vehicle), start=start)  # type: ignore[arg-type]
    if sim.blocked_at(*start) is not None:
        return None
    gx, gy = goal
    n_head = int(round(2.0 * math.pi / TURN_RAD))

    def key(x: float, y: float, yaw: float) -> tuple[int, int, int]:
        return (int(math.floor(x / _CELL)), int(math.floor(y / _CELL)), int(round(yaw / TURN_RAD)) % n_head)

    start_pose = (float(start[0]), float(start[1]), float(start[2]))
    parents: dict[tuple[int, int, int], tuple[tuple[float, float, float], tuple[int, int, int] | None]] = {
        key(*start_pose): (start_pose, None)}
    cost = {key(*start_pose): 0.0}
    heap = [(_GREED * math.hypot(gx - start_pose[0], gy - start_pose[1]), 0.0, key(*start_pose))]
    expansions = 0
    while heap and expansions < max_expansions:
        _, g, k = heapq.heappop(heap)
        if g > cost[k]:
            continue
        expansions += 1
        pose = parents[k][0]
        if math.hypot(gx - pose[0], gy - pose[1]) <= reach:
            track = []
            kk: tuple[int, int, int] | None = k
            while kk is not None:
                p, kk = parents[kk]
                track.append(p)
            return np.asarray(track[::-1], np.float64)
        for turn in (0.0, TURN_RAD, -TURN_RAD):
            ok = True
            p = pose
            for _ in range(_CHECKS):
                p = integrate_arc(p[0], p[1], p[2], STEP_M / _CHECKS, turn / _CHECKS)
                if sim.blocked_at(*p) is not None:
                    ok = False
                    break
            if not ok:
                continue
            nk = key(*p)
            ng = g + STEP_M * (1.05 if turn else 1.0)
            if ng < cost.get(nk, math.inf):
                cost[nk] = ng
                parents[nk] = (p, k)
                heapq.heappush(heap, (ng + _GREED * math.hypot(gx - p[0], gy - p[1]), ng, nk))
    return None
