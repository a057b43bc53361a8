"""POSITION ESTIMATOR core: an extended Kalman filter on the world←vehicle pose (x [m], y [m], yaw [rad]).

Prediction composes odometry increments (motion of the vehicle in the `local` frame, expressed in
the vehicle frame); updates take perception fixes in the `world` frame, either a full point fix
(x, y, yaw with a 3×3 covariance) or a line fix (the vehicle lies on a line: only the cross-line
component is observed, optionally also the heading). A fix measured at an earlier time is
related to the current state through the odometry motion since then, so fixes that arrive late
(perception takes time) are still used correctly. `world_from_local` gives the perceived
correction world←local for the blackboard.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from wire.se2 import between, compose, inverse, wrap_angle
from modules.pilot.errors import PilotError

__all__ = ["OdometryNoise", "PointFix", "LineFix", "PoseFilter", "EstimatorError", "FixRefused"]


class EstimatorError(PilotError, ValueError):
    """A fix or increment is unusable (non-finite, not positive definite, degenerate line)."""


class FixRefused(EstimatorError):
    """A fix outside the estimate's gate: refused, the estimate unchanged."""


class OdometryNoise(BaseModel):
    """Odometry drift model: variance growth per metre travelled and per radian turned."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    along_var_per_m: float = Field(0.02**2 * 10, ge=0.0, description="[m²/m] along-track variance growth")
    cross_var_per_m: float = Field(0.02**2 * 10, ge=0.0, description="[m²/m] cross-track variance growth")
    yaw_var_per_m: float = Field(math.radians(0.5) ** 2, ge=0.0, description="[rad²/m] heading variance growth")
    yaw_var_per_rad: float = Field(math.radians(1.0) ** 2, ge=0.0, description="[rad²/rad] heading growth when turning")

    def covariance(self, delta: np.ndarray) -> np.ndarray:
        """Return the 3×3 covariance of an increment (dx [m], dy [m], dyaw [rad]) in the vehicle frame."""
        d = math.hypot(delta[0], delta[1])
        return np.diag(
            [
                self.along_var_per_m * d + 1e-9,
                self.cross_var_per_m * d + 1e-9,
                self.yaw_var_per_m * d + self.yaw_var_per_rad * abs(delta[2]) + 1e-12,
            ]
        )


@dataclass(frozen=True)
class PointFix:
    """A full pose fix: world←vehicle (x [m], y [m], yaw [rad]) at the image time, with a 3×3 covariance."""

    pose: np.ndarray
    cov: np.ndarray


@dataclass(frozen=True)
class LineFix:
    """A line fix in the world frame: the vehicle lies on the line through `point` with direction `angle`.

    `cross_var` [m²] is the variance across the line; `yaw`/`yaw_var` optionally also fix the heading [rad].
    """

    point: np.ndarray
    angle: float
    cross_var: float
    yaw: float | None = None
    yaw_var: float | None = None


def _check_pd(m: np.ndarray, what: str) -> None:
    if m.shape[0] != m.shape[1] or not np.all(np.isfinite(m)):
        raise EstimatorError(f"{what}: covariance must be a finite square matrix")
    if not np.allclose(m, m.T, atol=1e-9):
        raise EstimatorError(f"{what}: covariance must be symmetric")
    if np.any(np.linalg.eigvalsh(m) <= 0.0):
        raise EstimatorError(f"{what}: covariance must be positive definite")


class PoseFilter:
    """Fuse odometry increments and perception fixes into the world←vehicle pose and its covariance."""

    def __init__(self, pose: np.ndarray, cov: np.ndarray, noise: OdometryNoise = OdometryNoise(), *,
                 gate: float | None = None) -> None:
        """Start at world←vehicle `pose` (3,) [m, m, rad] with covariance `cov` (3,3).

        With `gate`, a fix whose innovation has a squared Mahalanobis distance above it is refused
        (EstimatorError) instead of applied: a wrong landmark association must not drag the estimate.
        """
        pose = np.asarray(pose, dtype=np.float64).reshape(3)
        cov = np.asarray(cov, dtype=np.float64).reshape(3, 3)
        if not np.all(np.isfinite(pose)):
            raise EstimatorError("initial pose must be finite")
        _check_pd(cov, "initial pose")
        # imported here: filterpy imports scipy.stats (0.4 s), and every module that reads the PILOT's
        # config imports this file, while only the position estimators build a filter
        from filterpy.kalman import ExtendedKalmanFilter

        self._ekf = ExtendedKalmanFilter(dim_x=3, dim_z=3)
        self._ekf.x = pose.reshape(3, 1).copy()
        self._ekf.P = cov.copy()
        self.noise = noise
        self.gate = gate
        self.fixes_used = 0
        self.distance_m = 0.0
        self.distance_since_fix_m = 0.0

    @property
    def pose(self) -> np.ndarray:
        """Return the estimated world←vehicle pose (3,) [m, m, rad]."""
        return self._ekf.x.reshape(3).copy()

    @property
    def cov(self) -> np.ndarray:
        """Return the estimate's covariance (3,3) [m², m·rad, rad²]."""
        return self._ekf.P.copy()

    def inflate(self, factor: float, max_sigma_xy: float, max_sigma_yaw: float) -> None:
        """Scale the covariance by `factor` (> 1), each axis capped at `max_sigma_xy` [m] / `max_sigma_yaw` [rad] std."""
        p = self._ekf.P * float(factor)
        caps = np.array([max_sigma_xy, max_sigma_xy, max_sigma_yaw]) ** 2
        scale = np.sqrt(np.minimum(1.0, np.maximum(caps, np.diag(self._ekf.P)) / np.diag(p)))
        p = (scale[:, None] * p) * scale[None, :]
        self._ekf.P = 0.5 * (p + p.T)

    def predict(self, delta: np.ndarray) -> None:
        """Apply an odometry increment (dx [m], dy [m], dyaw [rad]) expressed in the vehicle frame."""
        delta = np.asarray(delta, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(delta)):
            raise EstimatorError("odometry increment must be finite")
        x = self.pose
        c, s = math.cos(x[2]), math.sin(x[2])
        f = np.array([[1.0, 0.0, -s * delta[0] - c * delta[1]], [0.0, 1.0, c * delta[0] - s * delta[1]], [0.0, 0.0, 1.0]])
        g = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        self._ekf.x = compose(x, delta).reshape(3, 1)
        p = f @ self._ekf.P @ f.T + g @ self.noise.covariance(delta) @ g.T
        self._ekf.P = 0.5 * (p + p.T)
        d = math.hypot(delta[0], delta[1])
        self.distance_m += d
        self.distance_since_fix_m += d

    def _update(self, z: np.ndarray, h, r: np.ndarray, residual, gate: float | None = None) -> None:
        x0 = self.pose
        eps = 1e-6
        z0 = h(x0)
        jac = np.zeros((len(z0), 3))
        for k in range(3):
            dx = np.zeros(3)
            dx[k] = eps
            jac[:, k] = residual(h(x0 + dx), z0) / eps
        gate = self.gate if gate is None else gate
        if gate is not None:
            y = residual(np.asarray(z, dtype=np.float64).reshape(-1), z0)
            d2 = float(y @ np.linalg.solve(jac @ self._ekf.P @ jac.T + r, y))
            if not d2 <= gate:
                raise FixRefused(f"fix refused: squared Mahalanobis distance {d2:.1f} > gate {gate:g}")
        self._ekf.dim_z = len(z0)
        self._ekf.update(
            z.reshape(-1, 1),
            HJacobian=lambda _x: jac,
            Hx=lambda x: h(x.reshape(3)).reshape(-1, 1),
            R=r,
            residual=lambda a, b: residual(a.reshape(-1), b.reshape(-1)).reshape(-1, 1),
        )
        self._ekf.x[2, 0] = wrap_angle(float(self._ekf.x[2, 0]))
        self._ekf.P = 0.5 * (self._ekf.P + self._ekf.P.T)
        self.fixes_used += 1
        self.distance_since_fix_m = 0.0

    def update_point(self, fix: PointFix, motion_since: np.ndarray | None = None) -> None:
        """Correct with a full pose fix taken before the latest increment `motion_since` (vehicle frame)."""
        z = np.asarray(fix.pose, dtype=np.float64).reshape(3)
        r = np.asarray(fix.cov, dtype=np.float64).reshape(3, 3)
        if not np.all(np.isfinite(z)):
            raise EstimatorError("point fix: pose must be finite")
        _check_pd(r, "point fix")
        back = inverse(np.zeros(3) if motion_since is None else np.asarray(motion_since, dtype=np.float64))
        r = r + self.noise.covariance(back)

        def h(x: np.ndarray) -> np.ndarray:
            return compose(x, back)

        def res(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            d = a - b
            d[2] = wrap_angle(d[2])
            return d

        self._update(z, h, r, res)

    def update_position(self, xy: np.ndarray, cov: np.ndarray, motion_since: np.ndarray | None = None, *,
                        gate: float | None = None) -> None:
        """Correct with a position-only fix (x, y) [m] `world`, covariance (2,2) [m²], taken before `motion_since`.

        `gate` (a χ² bound on the squared Mahalanobis distance, 2 degrees of freedom) overrides the
        filter's own for this fix; a fix outside it raises EstimatorError and changes nothing.
        """
        z = np.asarray(xy, dtype=np.float64).reshape(2)
        r = np.asarray(cov, dtype=np.float64).reshape(2, 2)
        if not np.all(np.isfinite(z)):
            raise EstimatorError("position fix: position must be finite")
        _check_pd(r, "position fix")
        back = inverse(np.zeros(3) if motion_since is None else np.asarray(motion_since, dtype=np.float64))
        r = r + self.noise.covariance(back)[:2, :2]

        def h(x: np.ndarray) -> np.ndarray:
            return compose(x, back)[:2]

        self._update(z, h, r, lambda a, b: a - b, gate=gate)

    def update_line(self, fix: LineFix, motion_since: np.ndarray | None = None) -> None:
        """Correct with a line fix taken before the latest increment `motion_since` (vehicle frame)."""
        p0 = np.asarray(fix.point, dtype=np.float64).reshape(2)
        if not (np.all(np.isfinite(p0)) and math.isfinite(fix.angle) and math.isfinite(fix.cross_var)):
            raise EstimatorError("line fix: point, angle and variance must be finite")
        if fix.cross_var <= 0.0:
            raise EstimatorError("line fix: cross variance must be > 0")
        back = inverse(np.zeros(3) if motion_since is None else np.asarray(motion_since, dtype=np.float64))
        extra = self.noise.covariance(back)
        n = np.array([-math.sin(fix.angle), math.cos(fix.angle)])
        use_yaw = fix.yaw is not None and fix.yaw_var is not None
        if use_yaw and not (math.isfinite(fix.yaw) and fix.yaw_var > 0.0):
            raise EstimatorError("line fix: yaw must be finite and yaw_var > 0")

        def h(x: np.ndarray) -> np.ndarray:
            p = compose(x, back)
            out = [float(n @ (p[:2] - p0))]
            if use_yaw:
                out.append(p[2])
            return np.array(out)

        def res(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            d = a - b
            if use_yaw:
                d[1] = wrap_angle(d[1])
            return d

        if use_yaw:
            z = np.array([0.0, float(fix.yaw)])
            r = np.diag([fix.cross_var + max(extra[0, 0], extra[1, 1]), float(fix.yaw_var) + extra[2, 2]])
        else:
            z = np.array([0.0])
            r = np.array([[fix.cross_var + max(extra[0, 0], extra[1, 1])]])
        self._update(z, h, r, res)

    def world_from_local(self, local_vehicle: np.ndarray) -> np.ndarray:
        """Return world←local given the current local←vehicle odometry pose (3,) [m, m, rad]."""
        return compose(self.pose, inverse(np.asarray(local_vehicle, dtype=np.float64).reshape(3)))

    @staticmethod
    def motion(local_then: np.ndarray, local_now: np.ndarray) -> np.ndarray:
        """Return the vehicle-frame motion between two local←vehicle odometry poses (3,)."""
        return between(np.asarray(local_then, dtype=np.float64), np.asarray(local_now, dtype=np.float64))
