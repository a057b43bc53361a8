"""The search's cached heuristic: distance to go on a coarse grid of pyramid nodes, around the obvious obstacles.

One Dijkstra per plan, from the goal, over the pyramid's nodes of about `cell` [m]: a node is an
*obstacle* when its features alone say no wheel may stand on it — a discontinuity above the
vehicle's step, a slope beyond its tip-over limits, or unknown cells — and crossing it costs
`obstacle_cost` times its length; nodes within the body's half-width of an obstacle cost
`near_cost` times. The heuristic is the larger of this and the straight-line distance: not a lower
bound (the search is weighted anyway), but it steers the search around ditches and boulder fields
instead of into them. Frames: node (row, col) of the pyramid's level `level`; distances [m].
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from modules.terrain.pyramid import F_CELLS, F_COUNT, F_DISC, F_SLOPE, TerrainPyramid
from modules.terrain.vehicle_model import TerrainVehicle

__all__ = ["CostToGo", "cost_to_go"]


@dataclass(frozen=True)
class CostToGo:
    """Distance to go [m] from each node of pyramid level `level` (side `size` [m]): (rows, cols) float64."""

    level: int
    size: float
    distance: np.ndarray


def cost_to_go(pyramid: TerrainPyramid, vehicle: TerrainVehicle, start_x: float, start_y: float, goal_x: float,
               goal_y: float, cell: float = 0.8, obstacle_cost: float = 20.0, near_cost: float = 3.0,
               reach: float = 2.0) -> CostToGo:
    """Return the distance to go to (goal_x, goal_y) [m] over nodes about `cell` [m] wide, as far as the search may need it.

    The expansion stops past `reach` times the start's distance to go (plus 10 m): nodes beyond keep
    that bound, larger than any distance found.
    """
    res = pyramid.resolution
    k = min(pyramid.levels - 1, max(0, int(round(math.log2(max(cell, res) / res)))))
    size = res * 2 ** k
    h, w = (int(d) for d in pyramid.dims[k])
    nodes = pyramid.features[pyramid.offsets[k]:pyramid.offsets[k + 1]]
    limit = math.tan(min(vehicle.max_pitch, vehicle.max_roll))
    with np.errstate(invalid="ignore"):
        blocked = ((nodes[:, F_DISC] > vehicle.max_step) | (nodes[:, F_SLOPE] > limit)
                   | (nodes[:, F_COUNT] < nodes[:, F_CELLS])).reshape(h, w)
    cost = np.where(blocked, obstacle_cost, 1.0)
    near = int(math.ceil(vehicle.body_half_width / size))
    grown = blocked.copy()
    for di in range(-near, near + 1):
        for dj in range(-near, near + 1):
            if (di * di + dj * dj) * size * size <= (vehicle.body_half_width + 0.5 * size) ** 2:
                grown[max(0, di):h + min(0, di), max(0, dj):w + min(0, dj)] |= \
                    blocked[max(0, -di):h + min(0, -di), max(0, -dj):w + min(0, -dj)]
    cost = np.where(~blocked & grown, near_cost, cost)
    gi = min(h - 1, max(0, int((goal_y - pyramid.origin_y) / size)))
    gj = min(w - 1, max(0, int((goal_x - pyramid.origin_x) / size)))
    si = min(h - 1, max(0, int((start_y - pyramid.origin_y) / size)))
    sj = min(w - 1, max(0, int((start_x - pyramid.origin_x) / size)))
    return CostToGo(k, size, _dijkstra(cost, gi, gj, si, sj, size, reach))


@njit(cache=True, nogil=True, boundscheck=False)
def _dijkstra(cost: np.ndarray, gi: int, gj: int, si: int, sj: int, size: float, reach: float) -> np.ndarray:
    """Return the (rows, cols) cheapest distance [m] to node (gi, gj), 8-connected, a step weighed by its two nodes' mean cost.

    Stops once the distances pass `reach` × the start node's (si, sj) + 10 m; nodes not settled get that bound.
    """
    h, w = cost.shape
    dist = np.full((h, w), np.inf)
    done = np.zeros((h, w), np.bool_)
    dist[gi, gj] = 0.0
    heap = [(0.0, gi * w + gj)]
    diag = math.sqrt(2.0) * size
    limit = np.inf
    while len(heap) > 0:
        d, n = heapq.heappop(heap)
        i, j = n // w, n % w
        if d > dist[i, j]:
            continue
        if d > limit:
            break
        done[i, j] = True
        if i == si and j == sj:
            limit = reach * d + 10.0
        for di in range(-1, 2):
            for dj in range(-1, 2):
                if di == 0 and dj == 0:
                    continue
                a, b = i + di, j + dj
                if a < 0 or a >= h or b < 0 or b >= w:
                    continue
                nd = d + (diag if di != 0 and dj != 0 else size) * 0.5 * (cost[i, j] + cost[a, b])
                if nd < dist[a, b]:
                    dist[a, b] = nd
                    heapq.heappush(heap, (nd, a * w + b))
    if limit < np.inf:
        for i in range(h):
            for j in range(w):
                if not done[i, j]:
                    dist[i, j] = limit
    return dist
