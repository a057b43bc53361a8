"""A step's progress along its route as the robot believes it: how far along, how much is left, when it last got farther.

Shared by both mission services (the CAPTAIN under CODGER, EDDIE's mission service), so `sidewalk
status` reads the same figures from either: the believed position (`world` [m]) is projected onto the
step's route; the step made progress when the route left shrank by `progress_m` [m] since the last
progress. A new plan of the same step (a replan) is no progress: the first look along it is its baseline.
"""

from __future__ import annotations

import math
from typing import Sequence

from shapely.geometry import LineString, Point

from modules.vocabulary import Pose, StepProgress, Waiting

__all__ = ["RouteProgress", "PROGRESS_M"]

#: Getting this much farther along the route [m] is progress.
PROGRESS_M = 0.5


class RouteProgress:
    """Follow one step's believed progress along its route (N, 2) [m] in `world`; pure (fed sim time and positions)."""

    def __init__(self, step_index: int, route: Sequence[tuple[float, float]], now: float, *, progress_m: float = PROGRESS_M) -> None:
        """Start at sim time `now` [s]: no progress yet (the first look at the route counts as progress)."""
        self.step_index = step_index
        self.progress_m = progress_m
        self.line = LineString(route)
        #: the least route left [m] seen at a progress, and when [s sim]
        self.best_left = math.inf
        self.best_at = now
        self.last_left: float | None = None

    def reroute(self, route: Sequence[tuple[float, float]]) -> None:
        """Measure along a new plan of the step from now on; its first look is a baseline, not progress."""
        self.line = LineString(route)
        self.best_left = math.nan

    def left(self, xy: tuple[float, float]) -> float:
        """Return how much of the route [m] is left past the projection of `xy` onto it."""
        return float(self.line.length - self.line.project(Point(xy)))

    def note(self, now: float, left: float) -> bool:
        """Record `left` [m] at sim time `now` [s]; return whether it is progress."""
        self.last_left = left
        if math.isnan(self.best_left):
            self.best_left = left
            return False
        if left < self.best_left - self.progress_m:
            self.best_left, self.best_at = left, now
            return True
        return False

    def since(self, now: float) -> float:
        """Return the sim time [s] since the last progress (or the start)."""
        return max(0.0, now - self.best_at)

    def report(self, now: float, pose: tuple[float, float, float] | None, waiting: Waiting = "") -> StepProgress:
        """Return the progress at sim time `now` [s] with the believed `pose` (x, y [m], yaw [rad] in `world`; None: none)."""
        left = self.last_left if pose is None else self.left(pose[:2])
        length = float(self.line.length)
        return StepProgress(
            sim_time_s=now, step_index=self.step_index,
            route_done_m=None if left is None else max(0.0, length - left), route_left_m=None if left is None else max(0.0, left),
            pose=None if pose is None else Pose(x=pose[0], y=pose[1], yaw=pose[2]),
            since_progress_s=self.since(now), progress_m=self.progress_m, waiting=waiting)
