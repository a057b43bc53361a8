"""Map matching by E(T) (Navlab 1990 §2.3.5): the transform between two images' maps that best overlays their terrain.

Two maps of the same ground built from two images with the pose estimates of their moments disagree
by the error T of the second estimate relative to the first. For a trial T, every cell p of the
first (fixed) map has a height z1(p) and the second (moving) map a height z2 at T⁻¹(p), the point
that T carries onto p; E(T) = Σ (z1 − z2 − dz)² over the cells both maps know, the smooth ones left
out (they say little about T: a cell counts where the fixed map's slope is at least `min_slope`).
T = (dx, dy, dyaw) is a turn by dyaw about `pivot` (the second vehicle position) and a shift; dz is
the height offset of the two maps, found with it. E is minimised by Gauss-Newton with
Levenberg-Marquardt damping from an initial estimate (the INS's, here the pose estimate: T = 0),
coarse to fine: the maps are first averaged into coarse cells (a wide, smooth basin), and each level
starts from the one before. A robust (Huber) weight keeps cells one map sees and the other sees
differently (a shadow's rim, a crown) from pulling T.

The result corrects the second pose estimate (`MatchResult.correct`). Frames: both maps in one frame
(`world`), on one lattice; angles [rad], lengths [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from modules.terrain.elevation_grid import ElevationGrid
from modules.terrain.errors import TerrainError
from modules.terrain.grid_spec import GridSpec
from modules.terrain.vehicle_pose import VehiclePose

__all__ = ["MatchParams", "MatchResult", "match_maps"]


@dataclass(frozen=True)
class MatchParams:
    """Levels [m] (cell sizes, coarse to fine), the slope [m/m] below which a cell is smooth, damping and stops."""

    levels: tuple[float, ...] = (1.6, 0.8, 0.4, 0.2)
    min_slope: float = 0.05
    huber: float = 1.5  # robust weight beyond this many cell sizes of residual [m per m of level]
    max_iterations: int = 25
    min_cells: int = 30
    tolerance: float = 1e-4  # stop when a step moves no cell more than this [m]


@dataclass(frozen=True)
class MatchResult:
    """T found: the moving map's ground truly lies turned by `dyaw` [rad] about `pivot` (x, y) [m], shifted by (dx, dy) [m]
    and raised by dz [m]; the RMS of z1 − z2 − dz [m] over the cells matched before and after, their count, iterations."""

    dx: float
    dy: float
    dyaw: float
    dz: float
    pivot: tuple[float, float]
    rms_before: float
    rms_after: float
    cells: int
    iterations: int

    def correct(self, pose: VehiclePose) -> VehiclePose:
        """Return the pose estimate the moving map was built with, corrected by T."""
        return pose.moved(self.dx, self.dy, self.dz, self.dyaw, self.pivot)


def _coarse(grid: ElevationGrid, k: int) -> tuple[np.ndarray, float, float]:
    """Return `grid`'s heights averaged over k × k blocks (NaN where fewer than half are known), and the new origin."""
    if k == 1:
        return grid.z.astype(np.float64), grid.origin_x, grid.origin_y
    ny, nx = grid.shape
    by, bx = ny // k, nx // k
    z = grid.z[:by * k, :bx * k].astype(np.float64).reshape(by, k, bx, k)
    known = np.isfinite(z)
    n = known.sum(axis=(1, 3))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(known, z, 0.0).sum(axis=(1, 3)) / n
    mean[n < (k * k) / 2] = np.nan
    return mean, grid.origin_x, grid.origin_y


def _sample(z: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the bilinear height and its gradient (per cell) at grid coordinates u (columns), v (rows); NaN off the map."""
    ny, nx = z.shape
    j = np.floor(u).astype(np.int64)
    i = np.floor(v).astype(np.int64)
    inside = (j >= 0) & (j < nx - 1) & (i >= 0) & (i < ny - 1)
    j, i = np.where(inside, j, 0), np.where(inside, i, 0)
    fu, fv = u - j, v - i
    z00, z01, z10, z11 = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]
    h = (z00 * (1 - fu) + z01 * fu) * (1 - fv) + (z10 * (1 - fu) + z11 * fu) * fv
    gu = (z01 - z00) * (1 - fv) + (z11 - z10) * fv
    gv = (z10 - z00) * (1 - fu) + (z11 - z01) * fu
    bad = ~inside
    return np.where(bad, np.nan, h), np.where(bad, np.nan, gu), np.where(bad, np.nan, gv)


def match_maps(fixed: ElevationGrid, moving: ElevationGrid, pivot: tuple[float, float],
               params: MatchParams = MatchParams()) -> MatchResult:
    """Return the T minimising E(T) between two maps of one lattice, starting from T = 0 (TerrainError if they barely overlap)."""
    GridSpec.of(fixed).offset_in(GridSpec.of(moving))
    res = fixed.resolution
    px, py = float(pivot[0]), float(pivot[1])
    theta = np.zeros(4)  # dx, dy, dyaw, dz
    first_rms, rms, cells, iterations = math.nan, math.nan, 0, 0
    for level in params.levels:
        k = max(1, int(round(level / res)))
        zf, fox, foy = _coarse(fixed, k)
        zm, mox, moy = _coarse(moving, k)
        cell = res * k
        gy, gx = np.gradient(zf, cell)
        ys, xs = np.nonzero(np.isfinite(zf) & (np.hypot(gx, gy) >= params.min_slope))
        if len(xs) < params.min_cells:
            continue
        X = fox + (xs + 0.5) * cell
        Y = foy + (ys + 0.5) * cell
        Z = zf[ys, xs]
        lam = 1e-3

        def residuals(th: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            c, s = math.cos(th[2]), math.sin(th[2])
            ex, ey = X - px - th[0], Y - py - th[1]
            qx = c * ex + s * ey + px  # T⁻¹(p): back by the shift, turned back by dyaw about the pivot
            qy = -s * ex + c * ey + py
            h, gu, gv = _sample(zm, (qx - mox) / cell - 0.5, (qy - moy) / cell - 0.5)
            r = Z - h - th[3]
            ok = np.isfinite(r)
            gxm, gym = gu[ok] / cell, gv[ok] / cell
            # dq/d(dx, dy) = -R(-dyaw); dq/d(dyaw) = dR(-dyaw)/d(dyaw) · (p - pivot - t)
            dqx_da, dqy_da = -s * ex[ok] + c * ey[ok], -c * ex[ok] - s * ey[ok]
            J = np.column_stack([gxm * c - gym * s, gxm * s + gym * c, -(gxm * dqx_da + gym * dqy_da), -np.ones(ok.sum())])
            return r[ok], J, ok

        def cost(r: np.ndarray) -> float:
            delta = params.huber * cell
            a = np.abs(r)
            return float(np.mean(np.where(a <= delta, 0.5 * r * r, delta * (a - 0.5 * delta)))) if len(r) else math.inf

        r, J, _ = residuals(theta)
        if len(r) < params.min_cells:
            continue
        if math.isnan(first_rms):
            first_rms = float(np.sqrt(np.mean(r * r)))
        e = cost(r)
        for _ in range(params.max_iterations):
            iterations += 1
            delta = params.huber * cell
            w = np.where(np.abs(r) <= delta, 1.0, delta / np.maximum(np.abs(r), 1e-12))
            A = J.T @ (J * w[:, None])
            b = -J.T @ (w * r)
            step = np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-9), b)
            trial = theta + step
            r2, J2, _ = residuals(trial)
            e2 = cost(r2)
            if len(r2) >= params.min_cells and e2 <= e:
                move = math.hypot(step[0], step[1]) + abs(step[2]) * 20.0
                theta, r, J, e = trial, r2, J2, e2
                lam = max(lam / 3.0, 1e-7)
                if move < params.tolerance:
                    break
            else:
                lam *= 4.0
                if lam > 1e6:
                    break
        rms, cells = float(np.sqrt(np.mean(r * r))), len(r)
    if cells == 0:
        raise TerrainError("map matching: the two maps share too few cells with relief to match")
    return MatchResult(float(theta[0]), float(theta[1]), float(theta[2]), float(theta[3]), (px, py), first_rms, rms, cells,
                       iterations)
