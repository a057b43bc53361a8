"""The vehicle's motion from tracked features, as FIDO and Moravec's Cart solved it.

A feature seen at two steps gives two 3-D points in the two vehicle frames; the motion between
the frames is the rigid transform that carries the new points onto the old ones. The vehicle stays
level, so the transform is a turn about the vertical and a translation:
p_previous = R_z(dyaw)·p_current + (dx, dy, dz). It is the weighted least-squares fit (each point's
residual weighted by the inverse of its two stereo covariances, so far points count little along
their rays), solved by Gauss–Newton from the closed-form unweighted fit. As on the Cart, the worst
feature is dropped and the fit repeated while any residual exceeds the χ² gate: tracks that jumped
to another point, or points that moved, leave one by one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modules.fido.errors import MotionError

__all__ = ["PlanarMotion", "Motion", "estimate_motion", "CHI2_3DOF_99"]

#: The 99 % quantile of χ² with 3 degrees of freedom: a residual beyond it is an outlier.
CHI2_3DOF_99 = 11.345


@dataclass(frozen=True)
class PlanarMotion:
    """A level vehicle's motion `previous ← current`: `dx`, `dy` [m] in the previous `vehicle` frame, turn `dyaw` [rad]."""

    dx: float
    dy: float
    dyaw: float

    def to_current(self, xyz: np.ndarray) -> np.ndarray:
        """Return points (N, 3) [m] of the previous `vehicle` frame in the current one."""
        p = np.asarray(xyz, np.float64).reshape(-1, 3) - (self.dx, self.dy, 0.0)
        return p @ _rot(self.dyaw)


@dataclass(frozen=True)
class Motion:
    """`previous ← current`: translation `dx`, `dy`, `dz` [m] and turn `dyaw` [rad] in the previous `vehicle`
    frame; `inliers` (N,) bool, the features the fit kept; `chi2` (N,) float64 each feature's Mahalanobis residual²."""

    dx: float
    dy: float
    dz: float
    dyaw: float
    inliers: np.ndarray
    chi2: np.ndarray

    @property
    def distance(self) -> float:
        """Return the horizontal distance moved [m]."""
        return math.hypot(self.dx, self.dy)

    @property
    def planar(self) -> PlanarMotion:
        """Return the motion in the ground plane."""
        return PlanarMotion(self.dx, self.dy, self.dyaw)


def _rot(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _closed_form(prev: np.ndarray, now: np.ndarray) -> np.ndarray:
    """Return (dx, dy, dz, dyaw) of the unweighted least-squares fit (2-D Kabsch in x-y, mean z)."""
    mp, mn = prev.mean(axis=0), now.mean(axis=0)
    a, b = now[:, :2] - mn[:2], prev[:, :2] - mp[:2]
    yaw = math.atan2(float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])), float(np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])))
    t = mp - _rot(yaw) @ mn
    return np.array([t[0], t[1], t[2], yaw])


def _fit(prev: np.ndarray, cp: np.ndarray, now: np.ndarray, cn: np.ndarray, iterations: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Return the weighted fit (dx, dy, dz, dyaw) and each point's χ² residual."""
    x = _closed_form(prev, now)
    for _ in range(iterations):
        R = _rot(x[3])
        r = prev - now @ R.T - x[:3]
        W = np.linalg.inv(cp + R @ cn @ R.T)
        c, s = math.cos(x[3]), math.sin(x[3])
        dR = np.array([[-s, -c, 0.0], [c, -s, 0.0], [0.0, 0.0, 0.0]])
        J = np.zeros((len(prev), 3, 4))
        J[:, :, :3] = -np.eye(3)
        J[:, :, 3] = -(now @ dR.T)
        JtW = J.transpose(0, 2, 1) @ W
        H = np.einsum("nij,njk->ik", JtW, J)
        g = np.einsum("nij,nj->i", JtW, r)
        step = -np.linalg.solve(H, g)
        x = x + step
        if np.max(np.abs(step)) < 1e-9:
            break
    R = _rot(x[3])
    r = prev - now @ R.T - x[:3]
    W = np.linalg.inv(cp + R @ cn @ R.T)
    return x, np.einsum("ni,nij,nj->n", r, W, r)


def estimate_motion(previous: np.ndarray, previous_cov: np.ndarray, current: np.ndarray, current_cov: np.ndarray, *,
                    gate: float = CHI2_3DOF_99, min_features: int = 3) -> Motion:
    """Return the motion `previous ← current` from the same features' points (N, 3) [m] and covariances (N, 3, 3) [m²]
    in the two `vehicle` frames; `MotionError` when fewer than `min_features` consistent ones remain."""
    p = np.asarray(previous, np.float64).reshape(-1, 3)
    q = np.asarray(current, np.float64).reshape(-1, 3)
    cp = np.asarray(previous_cov, np.float64).reshape(-1, 3, 3)
    cq = np.asarray(current_cov, np.float64).reshape(-1, 3, 3)
    if not (len(p) == len(q) == len(cp) == len(cq)):
        raise MotionError(f"motion: {len(p)} previous and {len(q)} current points ({len(cp)}, {len(cq)} covariances) do not pair up")
    ok = np.isfinite(p).all(axis=1) & np.isfinite(q).all(axis=1) & np.isfinite(cp).all(axis=(1, 2)) & np.isfinite(cq).all(axis=(1, 2))
    keep = np.nonzero(ok)[0]
    n = len(p)
    while True:
        if len(keep) < max(min_features, 2):
            raise MotionError(f"motion: {len(keep)} consistent tracked features of {n}, at least {max(min_features, 2)} needed")
        x, chi2 = _fit(p[keep], cp[keep], q[keep], cq[keep])
        worst = int(np.argmax(chi2))
        if chi2[worst] <= gate:
            break
        keep = np.delete(keep, worst)
    inliers = np.zeros(n, bool)
    inliers[keep] = True
    all_chi2 = np.full(n, np.inf)
    R = _rot(x[3])
    r = p[ok] - q[ok] @ R.T - x[:3]
    all_chi2[ok] = np.einsum("ni,nij,nj->n", r, np.linalg.inv(cp[ok] + R @ cq[ok] @ R.T), r)
    return Motion(dx=float(x[0]), dy=float(x[1]), dz=float(x[2]), dyaw=float(x[3]), inliers=inliers, chi2=all_chi2)
