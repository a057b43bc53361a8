"""DRIVING UNIT NAVIGATOR core: local path constraints from driving unit regions and segment constraints.

Frame: `world` [m]. The navigable region of each driving unit comes from PERCEPTION when it has
seen the unit, otherwise from the map's path objects copied into the segment description. The
union is shrunk by a margin (half the vehicle width plus a safety allowance); the goals are the
far edges of the driving units, shifted sideways to honour "keep right"/"keep left" as far as the
shrunk region allows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import shapely
from pydantic import BaseModel, ConfigDict, Field
from shapely.geometry.base import BaseGeometry

from modules.pilot.polyline import PathLine
from modules.pilot.errors import PilotError

__all__ = ["NavigatorConfig", "LocalConstraints", "ConstraintError", "local_constraints"]

KeepSide = Literal["right", "left", "none"]


class ConstraintError(PilotError, ValueError):
    """The driving units leave no room to drive (the region vanishes under the margin)."""


class NavigatorConfig(BaseModel):
    """Margin [m] kept from region edges and the sideways offset [m] used for keep-right/left."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    margin: float = Field(0.8, ge=0.0, description="distance kept from the region's edge [m]")
    keep_offset: float = Field(0.6, ge=0.0, description="lateral offset from the centerline for keep-right/left [m]")
    min_keep_offset_step: float = Field(0.1, gt=0.0, description="step when shrinking the offset or backing off [m]")
    max_goal_backoff: float = Field(3.0, ge=0.0, description="how far a goal may move back from a unit's far edge [m]")
    body_half_width: float = Field(0.0, ge=0.0, description="keep-right/left never pushes the body off the region [m]")
    obstacle_clearance: float = Field(1.0, ge=0.0, description="distance kept from standing objects (posts, trees, walls) [m]")
    uncertainty_gain: float = Field(1.0, ge=0.0, description="extra obstacle clearance per metre of position σ [-]")
    uncertainty_cap: float = Field(1.0, ge=0.0, description="most extra clearance the uncertainty adds [m]")
    footprint_x: tuple[float, ...] = Field((0.0,), min_length=1, description="points along the vehicle axis a goal must fit [m]")


@dataclass(frozen=True)
class LocalConstraints:
    """Shrunk navigable region (world), goal poses (K,3) [m, m, rad] at arc lengths goal_s (K,) [m], offset [m, left +]."""

    region: BaseGeometry
    goals: np.ndarray
    goal_s: np.ndarray
    lateral_offset: float
    perceived: tuple[bool, ...]


def _fits(region: BaseGeometry, q: np.ndarray, h: float, fx: np.ndarray) -> bool:
    return bool(shapely.contains_xy(region, q[0] + fx * math.cos(h), q[1] + fx * math.sin(h)).all())


def _fit_offset(region: BaseGeometry, path: PathLine, s: float, want: float, step: float, fx: np.ndarray) -> float | None:
    """Return the largest offset ≤ |want| toward `want` whose footprint fits at arc length s, or None."""
    p = path.point_at(s)
    h = path.heading_at(max(0.0, s - 1e-6))
    n = np.array([-math.sin(h), math.cos(h)])
    off = want
    while True:
        if _fits(region, p + off * n, h, fx):
            return off
        if off == 0.0:
            return None
        off = math.copysign(max(0.0, abs(off) - step), off)


def local_constraints(
    path: PathLine,
    unit_regions: list[BaseGeometry],
    unit_far_s: list[float],
    perceived: list[bool],
    keep: KeepSide = "none",
    cfg: NavigatorConfig = NavigatorConfig(),
    lateral_offset: float | None = None,
    obstacles: tuple[BaseGeometry, ...] = (),
    sigma: float = 0.0,
) -> LocalConstraints:
    """Build constraints over the driving units ahead: regions (world), far-edge arc lengths s [m].

    `lateral_offset` [m, left +] overrides the offset `keep` would choose (the MAP NAVIGATOR's);
    either is reduced so the vehicle's body (`body_half_width`) stays on the region. Standing
    `obstacles` (world) are cut out with `obstacle_clearance`, widened by the position estimate's
    standard deviation `sigma` [m] (dead reckoning grows it: the vehicle may be off by that much).
    """
    if not unit_regions or len(unit_regions) != len(unit_far_s) or len(perceived) != len(unit_regions):
        raise ConstraintError("need one region, one far-edge arc length and one perceived flag per driving unit")
    union = shapely.union_all([r for r in unit_regions if not r.is_empty])
    if union.is_empty:
        raise ConstraintError("driving units have empty navigable regions")
    shrunk = union.buffer(-cfg.margin) if cfg.margin > 0 else union
    if obstacles:
        clearance = cfg.obstacle_clearance + min(cfg.uncertainty_cap, cfg.uncertainty_gain * max(0.0, sigma))
        shrunk = shapely.difference(shrunk, shapely.union_all([o.buffer(clearance) for o in obstacles]))
    if shrunk.is_empty:
        raise ConstraintError(f"navigable region is narrower than twice the margin {cfg.margin:.2f} m")
    shapely.prepare(shrunk)
    # Goals with a keep-right/left offset must leave the whole body on the region.
    body = union.buffer(-max(cfg.body_half_width, cfg.margin)) if cfg.body_half_width > cfg.margin else shrunk
    if obstacles and body is not shrunk:
        body = shapely.intersection(body, shrunk)
    shapely.prepare(body)
    want = {"right": -cfg.keep_offset, "left": cfg.keep_offset, "none": 0.0}[keep] if lateral_offset is None else lateral_offset
    goals: list[list[float]] = []
    goal_s: list[float] = []
    used = want
    for s_far in unit_far_s:
        # Step back from the far edge until the goal fits in the shrunk region (a segment's end
        # meets the region's end; the margin eats the last few decimetres).
        s, q, h, off = s_far, None, 0.0, 0.0
        fx = np.asarray(cfg.footprint_x, dtype=np.float64)
        while s >= max(0.0, s_far - cfg.max_goal_backoff):
            h = path.heading_at(max(0.0, s - 1e-6))
            n = np.array([-math.sin(h), math.cos(h)])
            fit = _fit_offset(body, path, s, want, cfg.min_keep_offset_step, fx)
            off = fit if fit is not None else 0.0
            cand = path.point_at(s) + off * n
            if _fits(shrunk, cand, h, fx):
                q = cand
                break
            s -= cfg.min_keep_offset_step
        if q is None:
            if s_far == unit_far_s[-1]:
                raise ConstraintError(f"far edge at s={s_far:.1f} m is outside the shrunk navigable region")
            continue  # an intermediate waypoint is only a guide: drop it
        goals.append([q[0], q[1], h])
        goal_s.append(s)
        used = off if abs(off) < abs(used) else used
    return LocalConstraints(region=shrunk, goals=np.array(goals), goal_s=np.array(goal_s), lateral_offset=used,
                            perceived=tuple(perceived))
