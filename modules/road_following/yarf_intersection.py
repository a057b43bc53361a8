"""YARF's intersection navigation (Navlab 1990 §5.6): detect the approach, locate the branch, plan into its lane.

"An autonomous road following system must detect that the vehicle is approaching an intersection,
use perception to locate the roads branching out from the intersection, and plan a path from the
current lane through the intersection into the desired lane of the next road segment." Each image
is painted into the local map (`local_map`), which integrates the images and remembers them:

1. **Approach**: along the road's spine (YARF's, kept in the map while YARF finds the road) the
   map is read at every feature of the cross-section, bin by bin; where, for `gap_m` or more, every
   feature seen is missing (no paint within `across_m` of where it should be) after a stretch
   where the road's features were painted, the road's features have disappeared: an intersection
   starts there. A dashed centre line or a broken edge leaves one feature missing at a time and an
   added lane moves one; only all of them missing together is an intersection. The start is
   remembered in the map: later images need not find it again.
2. **Branch**: knowing only the branch's cross-section (the same lane model) and the side the route
   turns to, every branch (where it leaves the road, at what angle) is scored by the paint the map
   holds on its features beyond the road's edge (its yellow centre line and its white edge stripes)
   — a feed-forward prediction of the features, checked against all the images so far.
3. **Path**: from the current lane along the road to the branch's near edge, a cubic (Hermite) turn
   into the branch's lane (`lane_offset_m`, + left of the branch's direction), and along it.

Everything is on the flat ground; the view's geometry (`IntersectionView`) is in `vehicle` [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict

from modules.road_following.camera import CameraGeometry
from modules.road_following.follower import Branch, RoadObservation, VehicleMotion
from modules.road_following.local_map import LocalMap, LocalMapConfig
from modules.road_following.yarf import LaneModel

__all__ = ["IntersectionConfig", "IntersectionView", "IntersectionNavigator"]


@dataclass(frozen=True)
class IntersectionConfig:
    """Thresholds of the approach, the branch search and the path ([m], [deg], shares)."""

    bin_m: float = 1.0
    look_from_m: float = 5.0  # the profile starts this far ahead of the vehicle
    gap_m: float = 5.0  # every feature missing for this long: the road's features have disappeared
    painted_before_m: float = 3.0  # … after at least this much painted road nearer
    paint_share: float = 0.25  # a cell holds paint when at least this share of its views saw it
    across_m: float = 0.3  # paint counts within this of where a feature should be
    road_half_width_m: float = 3.8
    branch_angles_deg: tuple[float, float] = (40.0, 140.0)  # from the road's direction, towards the turn
    angle_step_deg: float = 2.0
    along_step_m: float = 0.5
    branch_search_m: float = 16.0  # the branch's centre leaves the road this far past the intersection's start, at most
    branch_length_m: float = 15.0  # the branch's features scored beyond the road's edge
    min_seen: float = 0.25  # a branch needs this share of its feature samples seen
    plateau_share: float = 0.98  # branches scoring at least this share of the best tie with it
    lane_offset_m: float = -1.75  # the lane to turn into, left of the branch's spine (negative: right)
    exit_m: float = 4.0  # the turn ends this far past the road's edge, in the branch's lane
    beyond_m: float = 10.0  # the path carries on along the branch's lane


class IntersectionView(BaseModel):
    """What the navigator knows at one image: the intersection's start ahead [m] along the road (None: none seen),
    the branch (where along the road from the vehicle [m], its angle [rad] from the vehicle's x axis), the path (N, 2) [m] in `vehicle`."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    approach_m: float | None = None
    branch: Branch | None = None
    path: tuple[tuple[float, float], ...] = ()


def _plateau_middle(scores: np.ndarray, k: int, share: float) -> float:
    """Return the middle index of the run around `k` of `scores` (1-D) at least `share` of `scores[k]`."""
    floor = share * scores[k]
    lo = hi = k
    while lo > 0 and scores[lo - 1] >= floor:
        lo -= 1
    while hi < len(scores) - 1 and scores[hi + 1] >= floor:
        hi += 1
    return 0.5 * (lo + hi)


def _hermite(p0: np.ndarray, d0: np.ndarray, p1: np.ndarray, d1: np.ndarray, n: int = 20) -> np.ndarray:
    """Return n points (n, 2) of the cubic Hermite curve from p0 (tangent d0) to p1 (tangent d1)."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    h00, h10, h01, h11 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t, -2 * t**3 + 3 * t**2, t**3 - t**2
    return h00 * p0 + h10 * d0 + h01 * p1 + h11 * d1


class IntersectionNavigator:
    """Intersection navigation beside YARF on one camera: `observe` each image with YARF's road (see the module docstring)."""

    def __init__(self, camera: CameraGeometry, lane: LaneModel = LaneModel(), turn: Literal["left", "right"] = "left",
                 config: IntersectionConfig = IntersectionConfig(), map_config: LocalMapConfig = LocalMapConfig()) -> None:
        """Navigate the next intersection, turning `turn` into the branch's lane; the map starts at this vehicle frame."""
        self.camera = camera
        self.lane = lane
        self.turn = turn
        self.config = config
        self.map = LocalMap(map_config)
        self.spine: np.ndarray | None = None  # the road's centre in the map, (N, 2) [m], every `bin_m`, from behind the vehicle
        self.start: np.ndarray | None = None  # the intersection's start in the map (2,) and the road's direction there (2,)
        self.start_dir: np.ndarray | None = None
        self.branch: tuple[np.ndarray, np.ndarray, float] | None = None  # origin (2,), direction (2,), score, in the map

    # ---- 1. the approach -------------------------------------------------------------------------
    def _keep_spine(self, road: RoadObservation) -> None:
        xs = np.arange(-5.0, 45.0 + 1e-9, self.config.bin_m)
        ys = np.array([road.centre_at(float(x)) for x in xs])
        self.spine = self.map.to_map(np.stack([xs, ys], axis=-1))

    def _painted(self, pts: np.ndarray, normals: np.ndarray, offset: float, kind: str) -> tuple[np.ndarray, np.ndarray]:
        """Return for points (N, 2) on a spine whether the feature at `offset` [m] (along `normals`) was seen, and painted."""
        c = self.config
        t = np.arange(-c.across_m, c.across_m + 1e-9, self.map.config.cell)
        q = pts[:, None, :] + (offset + t)[None, :, None] * normals[:, None, :]
        ev = self.map.evidence(q, kind)
        seen = np.isfinite(ev).any(axis=1)
        return seen, np.nan_to_num(ev, nan=0.0).max(axis=1) >= c.paint_share

    def _find_start(self) -> None:
        c = self.config
        if self.spine is None:
            return
        d = np.gradient(self.spine, axis=0)
        d /= np.maximum(np.linalg.norm(d, axis=1), 1e-9)[:, None]
        n = np.stack([-d[:, 1], d[:, 0]], axis=1)
        ahead = self.map.to_vehicle(self.spine)[:, 0]
        use = ahead >= c.look_from_m
        seen_any = np.zeros(len(self.spine), int)
        painted_any = np.zeros(len(self.spine), bool)
        for f in self.lane.features:
            seen, painted = self._painted(self.spine, n, f.offset_m, f.kind)
            seen_any += seen
            painted_any |= painted & seen
        empty = use & (seen_any >= max(2, len(self.lane.features) - 1)) & ~painted_any
        need = int(round(c.gap_m / c.bin_m))
        before = int(round(c.painted_before_m / c.bin_m))
        for i in np.flatnonzero(empty):
            if i + need <= len(empty) and empty[i:i + need].all() and painted_any[max(0, i - 3 * before):i].sum() >= before:
                self.start, self.start_dir = self.spine[i].copy(), d[i].copy()
                return

    # ---- 2. the branch ---------------------------------------------------------------------------
    def _find_branch(self) -> None:
        c = self.config
        assert self.start is not None and self.start_dir is not None
        u = self.start_dir
        sign = 1.0 if self.turn == "left" else -1.0
        angles = sign * np.radians(np.arange(c.branch_angles_deg[0], c.branch_angles_deg[1] + 1e-9, c.angle_step_deg))
        along = np.arange(0.0, c.branch_search_m + 1e-9, c.along_step_m)
        dirs = np.stack([np.cos(angles) * u[0] - np.sin(angles) * u[1], np.sin(angles) * u[0] + np.cos(angles) * u[1]], axis=-1)  # (A, 2)
        origins = self.start[None, :] + along[:, None] * u[None, :]  # (S, 2)
        s = np.arange(c.road_half_width_m, c.road_half_width_m + c.branch_length_m, 0.2)  # along the branch
        best = (-1.0, 0, 0)
        total = np.zeros((len(along), len(angles)))
        seen_share = np.zeros((len(along), len(angles)))
        for f in self.lane.features:
            normal = np.stack([-dirs[:, 1], dirs[:, 0]], axis=-1)  # (A, 2)
            hits = np.zeros((len(along), len(angles)))
            seen_n = np.zeros((len(along), len(angles)))
            for t in np.arange(-c.across_m, c.across_m + 1e-9, 0.1):
                q = (origins[:, None, None, :] + s[None, None, :, None] * dirs[None, :, None, :]
                     + (f.offset_m + t) * normal[None, :, None, :])  # (S, A, L, 2)
                ev = self.map.evidence(q, f.kind)
                hits = np.maximum(hits, (np.nan_to_num(ev, nan=0.0) >= c.paint_share).mean(axis=2))
                seen_n = np.maximum(seen_n, np.isfinite(ev).mean(axis=2))
            total += hits
            seen_share += seen_n / len(self.lane.features)
        total = np.where(seen_share >= c.min_seen, total, -1.0)
        i, j = np.unravel_index(int(np.argmax(total)), total.shape)
        if total[i, j] > best[0] and total[i, j] > 0:
            # paint counts within ±across_m of a feature, so a run of neighbouring branches ties: take the run's middle
            a = _plateau_middle(total[:, j], i, c.plateau_share)
            g = _plateau_middle(total[i, :], j, c.plateau_share)
            ang = sign * np.radians(c.branch_angles_deg[0] + g * c.angle_step_deg)
            d = np.array([math.cos(ang) * u[0] - math.sin(ang) * u[1], math.sin(ang) * u[0] + math.cos(ang) * u[1]])
            self.branch = (self.start + a * c.along_step_m * u, d, float(total[i, j]) / len(self.lane.features))

    # ---- 3. the path -----------------------------------------------------------------------------
    def _path(self) -> np.ndarray:
        c = self.config
        assert self.branch is not None and self.start_dir is not None and self.spine is not None
        o, d, _ = self.branch
        u = self.start_dir
        n_u = np.array([-u[1], u[0]])
        n_d = np.array([-d[1], d[0]])
        here = self.map.to_map(np.zeros((1, 2)))[0]
        # the current lane: the road's spine moved by the lane's offset (the same side the branch's lane keeps)
        entry = o - u * c.road_half_width_m + n_u * c.lane_offset_m
        exit_ = o + d * (c.road_half_width_m + c.exit_m) + n_d * c.lane_offset_m
        k = np.linalg.norm(exit_ - entry)
        along_now = float((here - entry) @ u)
        straight = entry[None, :] + np.linspace(min(along_now, 0.0), 0.0, 8)[:, None] * u[None, :]
        turn = _hermite(entry, u * k, exit_, d * k)
        beyond = exit_[None, :] + np.linspace(0.0, c.beyond_m, 6)[:, None] * d[None, :]
        return self.map.to_vehicle(np.vstack([straight, turn[1:], beyond[1:]]))

    # ---- per image -------------------------------------------------------------------------------
    def observe(self, image: np.ndarray, motion: VehicleMotion | None, road: RoadObservation | None) -> IntersectionView:
        """Paint `image` into the map after the odometry `motion`, keep YARF's `road` when found; return what is known now."""
        if motion is not None:
            self.map.move(motion)
        self.map.add(self.camera.check_image(image), self.camera)
        if road is not None and road.found and self.start is None:
            self._keep_spine(road)
        if self.start is None:
            self._find_start()
        if self.start is None:
            return IntersectionView()
        self._find_branch()
        here = self.map.to_vehicle(self.start[None, :])[0]
        view = IntersectionView(approach_m=float(here[0]))
        if self.branch is None:
            return view
        o, d, score = self.branch
        ov = self.map.to_vehicle(o[None, :])[0]
        dv = self.map.to_vehicle(np.array([o, o + d]))
        ang = math.atan2(*(dv[1] - dv[0])[::-1])
        path = self._path()
        return view.model_copy(update={"branch": Branch(along_m=float(ov[0]), angle_rad=ang, probability=min(max(score, 0.0), 1.0)),
                                       "path": tuple((float(a), float(b)) for a, b in path)})
