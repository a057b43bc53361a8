"""FIDO as an obstacle sensor (Navlab 1990 §4.3.1): a step per stereo pair, the obstacle features along a path.

FIDO drove the Terregator by planning around the features it marked as obstacles; here its
obstacle features stand where the laser's obstacle points stand for the fast obstacle check
(OBSTACLE DETECTOR, obstacle stop): the distance along the vehicle's path to the first feature
inside its corridor. Between steps the vehicle's dead-reckoned motion (two `local` poses) guides
the tracking search, as FIDO used its dead reckoning; it is never the answer. The features are
FIDO's own: in clutter (leaves, shadows) its corner detector finds fewer of them on an obstacle,
and what it misses the check does not see, as the paper found outdoors.

While the vehicle stands, an obstacle feature counts only once a second viewpoint has confirmed it
(see `FidoWatchConfig.still_m`): a 4×4 template on a horizontal edge (a walk's far side against the
grass) matches at the wrong disparity and triangulates above the ground, and standing still the
same pair repeated such a mismatch for good. A real point stays where the vehicle's motion puts it;
a mismatch does not (FIDO's and the Cart's test of a track).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.fido.fido import FidoConfig, FidoMemory, FidoStep, fido_step
from modules.fido.motion import CHI2_3DOF_99, PlanarMotion
from modules.fido.stereo_pair import StereoPair, StereoRig

__all__ = ["FidoWatchConfig", "FidoSighting", "FidoObstacleWatch", "corridor_distance", "motion_between"]


class FidoWatchConfig(BaseModel):
    """The watch's settings: FIDO's own, the stereo pair's image side [px], and the features an obstacle needs."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    fido: FidoConfig = FidoConfig()
    stereo_size: int = Field(512, ge=64, le=2048, multiple_of=64)  # the paper's 512×512 pair
    # one, as the paper defines an obstacle ("a feature that the vehicle could not drive over"): the interest operator
    # keeps one feature in each of its 10×10 subimages, so a pedestrian 8–12 m ahead gives one or two at most
    min_features: int = Field(1, ge=1)
    #: a step this long after the last [s] sim starts over (the tracks are too old to find again)
    max_gap_s: float = Field(5.0, gt=0.0)
    #: obstacle features are kept for this many steps (this one included) in `local`, placed by dead reckoning (FIDO's
    #: world model of obstacles): the interest operator does not pick the same corner in every pair. Counted in steps,
    #: not seconds: on a loaded machine a step takes longer and the memory must still span the same number of looks
    remember_steps: int = Field(8, ge=1)
    #: while the vehicle moves, every obstacle feature counts from its first sighting (FIDO's obstacle: one feature); once
    #: it stands (it moved less than `still_m` [m] since the last pair), the pair repeats the last one's view, mismatches
    #: included, and only confirmed obstacles count: features tracked this many steps (found again where the vehicle's
    #: motion puts them, and kept by the motion fit's χ² gate, the Cart's pruning) while the vehicle moved
    #: `min_baseline_m` [m] since their first sighting, and features seen where a confirmed one stands (the χ² gate of
    #: their covariances and `odometry_sigma_m`). A horizontal edge matched at the wrong disparity, seen again from where
    #: the vehicle stood, held it for good; a real obstacle seen while braking for it is confirmed and holds the stop
    still_m: float = Field(0.05, ge=0.0)
    min_age: int = Field(1, ge=0)
    min_baseline_m: float = Field(0.2, ge=0.0)
    odometry_sigma_m: float = Field(0.1, gt=0.0)  # [m] dead reckoning's error between two sightings, each axis


@dataclass(frozen=True)
class FidoSighting:
    """The obstacle features that count at a step: `xyz` (M, 3) float64 `vehicle` [m] at the pair's `stamp` [s] sim
    (this step's and the remembered ones), how many of them this step added (`new`), and the step's feature count,
    tracked count and wall time [ms]."""

    xyz: np.ndarray
    new: int
    stamp: float
    features: int
    tracked: int
    step_ms: float


def motion_between(p0: tuple[float, float, float], p1: tuple[float, float, float]) -> PlanarMotion:
    """Return the motion `previous ← current` between two poses (x, y [m], yaw [rad]) of one frame (`local`)."""
    c, s = math.cos(p0[2]), math.sin(p0[2])
    dx, dy = p1[0] - p0[0], p1[1] - p0[1]
    return PlanarMotion(c * dx + s * dy, -s * dx + c * dy, math.remainder(p1[2] - p0[2], math.tau))


class FidoObstacleWatch:
    """FIDO stepped over a stream of stereo pairs: keeps its memory and the pose of the last step."""

    def __init__(self, cfg: FidoWatchConfig = FidoWatchConfig()) -> None:
        self.cfg = cfg
        self.memory: FidoMemory | None = None
        self._last: tuple[float, tuple[float, float, float]] | None = None
        # per step, newest last: the obstacle features that counted, (M, 3) float64 `local` [m], (M, 3, 3) float64 [m²],
        # and (M,) bool which of them were confirmed
        self._kept: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._first: dict[int, tuple[float, float]] = {}  # feature id → the vehicle's (x, y) `local` [m] at its first sighting
        self._confirmed: set[int] = set()  # ids of tracked features confirmed as obstacles
        self.steps = 0

    def step(self, pair: StereoPair, rig: StereoRig, pose_local: tuple[float, float, float]) -> FidoSighting:
        """Run a FIDO step on `pair` seen at `pose_local` (dead reckoning, `local`); return its obstacle features."""
        previous, odometry = self.memory, None
        stood = self._last is None or math.hypot(pose_local[0] - self._last[1][0], pose_local[1] - self._last[1][1]) < self.cfg.still_m
        if self._last is not None and 0.0 <= pair.stamp - self._last[0] <= self.cfg.max_gap_s:
            odometry = motion_between(self._last[1], pose_local)
        else:
            previous = None
        res: FidoStep = fido_step(pair, rig, previous, self.cfg.fido, odometry)
        self.memory, self._last = res.memory, (pair.stamp, tuple(pose_local))
        self.steps += 1
        f = res.features
        x, y, yaw = pose_local
        c, s = math.cos(yaw), math.sin(yaw)
        self._first = {int(i): self._first.get(int(i), (x, y)) for i in f.ids}
        self._confirmed &= self._first.keys()
        cand = np.nonzero(res.obstacle)[0]
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        in_local = f.xyz[cand] @ R.T + (x, y, 0.0)
        cov_local = R @ f.cov[cand] @ R.T
        moved = np.array([math.hypot(x - self._first[int(i)][0], y - self._first[int(i)][1]) for i in f.ids[cand]])
        ok = np.array([int(i) in self._confirmed for i in f.ids[cand]], bool).reshape(-1)
        ok |= (f.age[cand] >= self.cfg.min_age) & (moved.reshape(-1) >= self.cfg.min_baseline_m)
        if self._kept and not ok.all():
            ok[~ok] = self._near_confirmed(in_local[~ok], cov_local[~ok])
        self._confirmed |= {int(i) for i in f.ids[cand][ok]}
        counts = ok | (not stood)
        self._kept = [*self._kept, (in_local[counts], cov_local[counts], ok[counts])][-self.cfg.remember_steps:]
        kept = np.concatenate([k[0] for k in self._kept]).reshape(-1, 3)
        dx, dy = kept[:, 0] - x, kept[:, 1] - y
        xyz = np.column_stack([c * dx + s * dy, -s * dx + c * dy, kept[:, 2]])
        return FidoSighting(xyz=xyz, new=int(counts.sum()), stamp=pair.stamp, features=len(f),
                            tracked=int(f.tracked.sum()), step_ms=res.timing.total_ms)

    def _near_confirmed(self, p: np.ndarray, cp: np.ndarray) -> np.ndarray:
        """Return (M,) bool: which points `p` (M, 3) `local` [m] (covariances `cp` (M, 3, 3) [m²]) lie within the χ² gate
        of an obstacle feature confirmed at an earlier step (from anywhere: standing, the vehicle must go on seeing an
        obstacle it confirmed while it moved)."""
        q = np.concatenate([np.zeros((0, 3))] + [k[0][k[2]] for k in self._kept])
        cq = np.concatenate([np.zeros((0, 3, 3))] + [k[1][k[2]] for k in self._kept])
        if not len(q):
            return np.zeros(len(p), bool)
        odo = np.diag([self.cfg.odometry_sigma_m ** 2] * 2 + [0.0])
        S = cp[:, None] + cq[None] + odo  # (M, Q, 3, 3)
        d = p[:, None] - q[None]  # (M, Q, 3)
        chi2 = np.einsum("mqi,mqi->mq", d, np.linalg.solve(S, d[..., None])[..., 0])
        return (chi2 <= CHI2_3DOF_99).any(axis=1)

    def corridor_distance(self, sighting: FidoSighting, path: np.ndarray, half_width: float) -> float:
        """Return the distance along `path` (K, 2) [m] `vehicle` to the obstacle the sighting shows in the corridor [m]."""
        return corridor_distance(sighting.xyz[:, :2], path, half_width, self.cfg.min_features)


def corridor_distance(points: np.ndarray, path: np.ndarray, half_width: float, min_points: int = 1) -> float:
    """Return the arc length [m] along `path` (K, 2) float64 at which the `min_points`-th of `points` (M, 2) float64
    lying within `half_width` [m] of it stands (both in one frame); `inf` when fewer lie in the corridor."""
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    path = np.asarray(path, np.float64).reshape(-1, 2)
    if len(path) < 2 or len(pts) < min_points:
        return math.inf
    a, e = path[:-1], np.diff(path, axis=0)
    L = np.linalg.norm(e, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(L)])
    r = pts[:, None, :] - a[None]  # (M, K-1, 2)
    t = np.clip((r * e[None]).sum(-1) / np.maximum(L * L, 1e-12)[None], 0.0, 1.0)
    d = np.linalg.norm(r - t[..., None] * e[None], axis=-1)
    seg = np.argmin(d, axis=1)
    rows = np.arange(len(pts))
    inside = d[rows, seg] <= half_width
    if int(inside.sum()) < min_points:
        return math.inf
    s = np.sort((cum[seg] + t[rows, seg] * L[seg])[inside])
    return float(s[min_points - 1])
