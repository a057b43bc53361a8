"""POSITION CALIBRATOR: the vehicle pose that best lays detected outlines onto predicted ones.

Seed: Sidewalk 1986 §3.2.3. Detected boundary vertices (vehicle frame) are pulled onto the predicted
polygon edges (world frame) and detected trunks onto predicted centres; Gauss-Newton with re-association
and Huber weights gives the pose world←vehicle and its covariance. When the scene constrains only part
of the pose — parallel edges of a straight sidewalk, or one tree — the result is a line the vehicle lies
on instead of a point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modules.perception.errors import PerceptionError
from wire.se2 import wrap_angle

__all__ = [
    "EdgeObservation",
    "PointObservation",
    "CalibrationResult",
    "CalibrationError",
    "calibrate",
]


class CalibrationError(PerceptionError, RuntimeError):
    """Too few usable observations to fix the vehicle position."""


@dataclass(frozen=True)
class EdgeObservation:
    """Detected boundary points of one region and the edges of its predicted outline.

    `points` (N, 2) vehicle frame [m]; `normals` (N, 2) outward unit normals of the detected outline
    (vehicle frame) or None; `polygon` (M, 2) predicted exterior ring in the world frame [m], or
    `segments` (M, 2, 2) predicted edges (start, end) [m] in the world frame with the region on
    their left (outward normal on the right), for outlines with holes or several parts.
    """

    points: np.ndarray
    normals: np.ndarray | None
    polygon: np.ndarray | None = None
    segments: np.ndarray | None = None

    def edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (starts (M, 2), ends (M, 2), outward normals (M, 2)) in the world frame."""
        if self.segments is not None:
            a = np.asarray(self.segments[:, 0], dtype=np.float64)
            b = np.asarray(self.segments[:, 1], dtype=np.float64)
            d = b - a
            ln = np.maximum(np.linalg.norm(d, axis=1), 1e-9)
            return a, b, np.stack([d[:, 1], -d[:, 0]], axis=1) / ln[:, None]
        if self.polygon is None:
            raise ValueError("an EdgeObservation needs a polygon or segments")
        return _edges(self.polygon)


@dataclass(frozen=True)
class PointObservation:
    """A detected point (vehicle frame [m]) and the predicted point (world frame [m]) it is."""

    point: tuple[float, float]
    target: tuple[float, float]


@dataclass(frozen=True)
class CalibrationResult:
    """The fitted pose world←vehicle (x [m], y [m], yaw [rad]), covariance (3, 3) and its kind.

    `kind` is "point" when the pose is fixed, "line" when the position is free along
    `line_direction` [rad] (world) through (x, y); `yaw_known` says whether the heading is fixed.
    """

    pose: tuple[float, float, float]
    covariance: np.ndarray
    kind: str
    line_direction: float
    lateral_var: float
    yaw_known: bool
    residual_rms: float
    n_used: int


def _rot(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


def _edges(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ring = np.asarray(poly, dtype=np.float64)
    if np.allclose(ring[0], ring[-1]):
        ring = ring[:-1]
    x, y = ring[:, 0], ring[:, 1]
    area2 = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    if area2 < 0:
        ring = ring[::-1]
    a = ring
    b = np.roll(ring, -1, axis=0)
    d = b - a
    ln = np.maximum(np.linalg.norm(d, axis=1), 1e-9)
    out_n = np.stack([d[:, 1], -d[:, 0]], axis=1) / ln[:, None]  # outward for a CCW ring
    return a, b, out_n


def _nearest_edge(qx: np.ndarray, qy: np.ndarray, e: "_EdgeTerms") -> np.ndarray:
    """Return the distance (N, M) [m] of points (qx, qy) (N, 1) to the edges a → a + d of `e`.

    Component by component, the same operations as on (N, M, 2) arrays: t = clip((q - a)·d / |d|², 0, 1),
    distance |q - (a + t d)|.
    """
    ex = qx - e.ax
    ey = qy - e.ay
    t = ex * e.dx
    ey *= e.dy
    t += ey
    t /= e.l2
    np.maximum(t, 0.0, out=t)
    np.minimum(t, 1.0, out=t)
    ox = t * e.dx
    ox += e.ax
    np.subtract(qx, ox, out=ox)
    oy = np.multiply(t, e.dy, out=t)
    oy += e.ay
    np.subtract(qy, oy, out=oy)
    ox *= ox
    oy *= oy
    ox += oy
    return np.sqrt(ox, out=ox)


@dataclass(frozen=True)
class _EdgeTerms:
    """The edge observations' arrays, fixed over the iterations, stacked into one set.

    Points `p` (N, 2) vehicle frame [m] and predicted edges `a` → `a` + d (M, 2) world frame [m] of all
    observations; `parts` per observation: its rows and columns (slices), its points, its edges'
    outward normals and its points' normals (or None), as given, so the small matrix products run
    on the very shapes they always had; `apart` (N, M) bool marks a point and an edge of different
    observations (they never pair).
    """

    p: np.ndarray
    parts: tuple[tuple[slice, slice, np.ndarray, np.ndarray, np.ndarray | None], ...]
    a: np.ndarray
    on: np.ndarray
    ax: np.ndarray  # (1, M) edge starts x [m]
    ay: np.ndarray
    dx: np.ndarray  # (1, M) edge vectors x [m]
    dy: np.ndarray
    l2: np.ndarray  # (1, M) squared edge lengths [m²]
    apart: np.ndarray

    @classmethod
    def of(cls, edges: list[EdgeObservation]) -> "_EdgeTerms | None":
        """Stack the observations that have points; None when none has."""
        parts, ps, As, ds, ons = [], [], [], [], []
        n = m = 0
        for e in edges:
            if len(e.points) == 0:
                continue
            a, b, on = e.edges()
            p = np.asarray(e.points, dtype=np.float64)
            parts.append((slice(n, n + len(p)), slice(m, m + len(a)), p, on, None if e.normals is None else np.asarray(e.normals)))
            ps.append(p)
            As.append(a)
            ds.append(b - a)
            ons.append(on)
            n, m = n + len(p), m + len(a)
        if not parts:
            return None
        a, d = np.concatenate(As), np.concatenate(ds)
        apart = np.ones((n, m), dtype=bool)
        for rows, cols, *_ in parts:
            apart[rows, cols] = False
        l2 = np.maximum((d * d).sum(1), 1e-12)
        return cls(np.concatenate(ps), tuple(parts), a, np.concatenate(ons), a[None, :, 0].copy(), a[None, :, 1].copy(),
                   d[None, :, 0].copy(), d[None, :, 1].copy(), l2[None, :], apart)


def calibrate(
    edges: list[EdgeObservation],
    points: list[PointObservation],
    prior: tuple[float, float, float],
    *,
    gate: float = 2.0,
    final_gate: float = 0.6,
    huber: float = 0.15,
    normal_cos: float = 0.5,
    iterations: int = 12,
    prior_sigma: tuple[float, float, float] = (10.0, 10.0, 0.5),
    line_sigma: float = 1.0,
    yaw_sigma: float = 0.05,
    min_sigma: float = 0.05,
    parallel_fraction: float = 0.06,
) -> CalibrationResult:
    """Fit the pose world←vehicle from edge and point observations, starting at `prior`.

    A position standard deviation above `line_sigma` [m] along one direction (and below it across)
    makes the fix a line, and so does a scene whose edge normals nearly all point one way (less than
    `parallel_fraction` of them across); the heading counts as known when its std is below `yaw_sigma` [rad].
    """
    x = np.array(prior, dtype=np.float64)
    prior_info = np.diag(1.0 / np.square(prior_sigma))
    terms = _EdgeTerms.of(edges)
    prior_arr = np.array(prior)
    if terms is not None:
        rows = np.arange(len(terms.p))
        qv = np.empty_like(terms.p)  # detected points in the world frame [m]
    H = np.zeros((3, 3))
    rms = 0.0
    n_used = 0
    for it in range(iterations):
        g = gate + (final_gate - gate) * min(1.0, it / max(1, iterations // 2))
        R = _rot(x[2])
        dR = np.array([[-math.sin(x[2]), -math.cos(x[2])], [math.cos(x[2]), -math.sin(x[2])]])
        rows_j: list[np.ndarray] = []
        rows_r: list[np.ndarray] = []
        if terms is not None:
            for rs, _, p, _, _ in terms.parts:
                qv[rs] = p @ R.T + x[:2]
            dist = _nearest_edge(qv[:, 0:1], qv[:, 1:2], terms)
            bad = terms.apart.copy()
            for rs, cs, _, on, normals in terms.parts:
                if normals is not None:
                    nw = normals @ R.T
                    np.logical_not((nw @ on.T) >= normal_cos, out=bad[rs, cs])
            np.copyto(dist, np.inf, where=bad)
            k = np.argmin(dist, axis=1)
            ok = dist[rows, k] <= g
            if ok.any():
                k = k[ok]
                n = terms.on[k]
                r = ((qv[ok] - terms.a[k]) * n).sum(1)
                # points beyond a segment's ends keep the perpendicular (infinite-line) residual
                pdr = [p[ok[rs]] @ dR.T for rs, _, p, _, _ in terms.parts if ok[rs].any()]
                pdr = pdr[0] if len(pdr) == 1 else np.concatenate(pdr)
                rows_j.append(np.column_stack([n[:, 0], n[:, 1], (pdr * n).sum(1)]))
                rows_r.append(r)
        for po in points:
            p = np.asarray(po.point, dtype=np.float64)
            q = R @ p + x[:2]
            r = q - np.asarray(po.target)
            if np.linalg.norm(r) > g + 0.5:
                continue
            dq = dR @ p
            rows_j.append(np.array([[1.0, 0.0, dq[0]], [0.0, 1.0, dq[1]]]))
            rows_r.append(r)
        if not rows_r:
            raise CalibrationError(f"no detected vertex lies within {g:.2f} m of a predicted edge")
        J = np.vstack(rows_j)
        r = np.concatenate(rows_r)
        # Huber weights while far from converged, then Cauchy weights that all but ignore outliers
        if it < iterations // 3:
            w = np.where(np.abs(r) <= huber, 1.0, huber / np.maximum(np.abs(r), 1e-12))
        else:
            w = 1.0 / (1.0 + np.square(r / huber))
        Jw = J * w[:, None]
        H = Jw.T @ J
        gvec = Jw.T @ r
        prior_res = x - prior_arr
        prior_res[2] = wrap_angle(prior_res[2])
        step = np.linalg.solve(H + prior_info, -(gvec + prior_info @ prior_res))
        x = x + step
        rms = float(np.sqrt(np.sum(w * r * r) / max(np.sum(w), 1e-9)))
        n_used = len(r)
        if np.linalg.norm(step[:2]) < 1e-4 and abs(step[2]) < 1e-5 and it >= iterations // 2:
            break
    if n_used < 3:
        raise CalibrationError(f"only {n_used} residuals; a fix needs at least 3")
    sigma2 = max(rms, min_sigma) ** 2
    cov = sigma2 * np.linalg.inv(H + prior_info * sigma2)
    cov = 0.5 * (cov + cov.T)
    evals, evecs = np.linalg.eigh(cov[:2, :2])
    major = evecs[:, 1]
    direction = math.atan2(major[1], major[0])
    is_line = math.sqrt(max(evals[1], 0.0)) > line_sigma
    # The paper's test: a scene of (nearly) parallel edges only fixes the position across them. The
    # weighted orientation tensor of the residual normals has one tiny eigenvalue then; its
    # eigenvector is the line's direction, whatever few stray points say along it.
    Nn = J[:, :2]
    T = (Nn * w[:, None]).T @ Nn / max(float(np.sum(w)), 1e-9)
    tev, tvec = np.linalg.eigh(T)
    if tev[0] < parallel_fraction * max(float(tev.sum()), 1e-12):
        is_line = True
        along = tvec[:, 0]
        direction = math.atan2(along[1], along[0])
        across = np.array([-along[1], along[0]])
        evals = np.array([float(across @ cov[:2, :2] @ across), float(along @ cov[:2, :2] @ along)])
    yaw_known = math.sqrt(max(cov[2, 2], 0.0)) < yaw_sigma
    x[2] = wrap_angle(x[2])
    return CalibrationResult(
        pose=(float(x[0]), float(x[1]), float(x[2])),
        covariance=cov,
        kind="line" if is_line or not yaw_known else "point",
        line_direction=direction,
        lateral_var=float(max(evals[0], 0.0)),
        yaw_known=yaw_known,
        residual_rms=rms,
        n_used=n_used,
    )
