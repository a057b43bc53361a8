"""ALVINN's training views (Navlab 1990 §2.2.3): each image shifted and rotated, with the steering corrected.

A person drives along the road; each image is reused from several vantage points as if the vehicle
had been `dy` [m] to the side and turned by `dyaw` [rad]: every pixel below the horizon is a point
of the flat ground, seen again from the moved camera (pixels above the horizon only turn with the
vehicle). The steering that brings the vehicle back is pure pursuit to the road centre `lookahead`
metres ahead: curvature = 2·y / L², y the centre's lateral position at distance L (`vehicle` frame).
The same geometry read backwards gives the seed's road point: where the steering arc, followed for
L, meets the road centre. The retina is the reduced blue band, normalised per image.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from modules.road_following.camera import CameraGeometry

__all__ = ["retina", "shifted_view", "moved_line", "pursuit_curvature", "arc_road_point", "training_views"]


def retina(image: np.ndarray, rows: int = 30, cols: int = 32) -> np.ndarray:
    """Return the net's input for `image` (H, W, 3) uint8: the blue band reduced to rows × cols, zero mean, unit std, flat."""
    small = cv2.resize(image[..., 2], (cols, rows), interpolation=cv2.INTER_AREA).astype(np.float64)
    return ((small - small.mean()) / max(small.std(), 1.0)).ravel()


def _rotate(xy: np.ndarray, a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)


def shifted_view(image: np.ndarray, camera: CameraGeometry, dy_m: float, dyaw_rad: float) -> np.ndarray:
    """Return `image` as seen with the vehicle moved `dy_m` [m] to the left and turned `dyaw_rad` [rad] (flat ground)."""
    h, w = image.shape[:2]
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    g_new = camera.ground_points(u, v, max_range=150.0)  # ground seen by the moved camera, moved vehicle frame
    g_old = _rotate(g_new, dyaw_rad) + (0.0, dy_m)
    us, vs, _ = camera.project_ground(g_old)
    # sky and far ground: directions only turn with the vehicle
    d = camera.rays(u, v)
    d_old = np.concatenate([_rotate(d[..., :2], dyaw_rad), d[..., 2:]], axis=-1)
    pu, pv, _ = camera.project(camera.position + d_old)
    far = ~np.isfinite(g_new[..., 0])
    us = np.where(far, pu, us)
    vs = np.where(far, pv, vs)
    return cv2.remap(image, us.astype(np.float32), vs.astype(np.float32), cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def moved_line(line_xy: np.ndarray, dy_m: float, dyaw_rad: float) -> np.ndarray:
    """Return a polyline (N, 2) [m] of the old `vehicle` frame in the frame of the vehicle moved by (dy, dyaw)."""
    return _rotate(np.asarray(line_xy, float) - (0.0, dy_m), -dyaw_rad)


def pursuit_curvature(line_xy: np.ndarray, lookahead_m: float) -> float:
    """Return the curvature [1/m] of the arc from the vehicle to the road centre `line_xy` (N, 2) at distance L ahead."""
    p = np.asarray(line_xy, float)
    d = np.hypot(p[:, 0], p[:, 1])
    ahead = p[:, 0] > 0.0
    idx = np.flatnonzero(ahead & (d >= lookahead_m))
    if len(idx) == 0:
        target = p[np.argmax(np.where(ahead, d, -1.0))]
    else:
        i = int(idx[0])
        if i > 0 and ahead[i - 1]:
            a, b = p[i - 1], p[i]
            da, db = d[i - 1], d[i]
            t = (lookahead_m - da) / max(db - da, 1e-9)
            target = a + t * (b - a)
        else:
            target = p[i]
    dist2 = float(target[0] ** 2 + target[1] ** 2)
    return 2.0 * float(target[1]) / max(dist2, 1e-9)


def arc_road_point(curvature: float, lookahead_m: float) -> tuple[float, float]:
    """Return where an arc of `curvature` [1/m] from the vehicle is `lookahead_m` [m] (chord) away: the road point in `vehicle`."""
    if abs(curvature) < 1e-9:
        return (lookahead_m, 0.0)
    half = math.asin(max(-1.0, min(1.0, lookahead_m * curvature / 2.0)))
    return (lookahead_m * math.cos(half), lookahead_m * math.sin(half))


def training_views(image: np.ndarray, camera: CameraGeometry, centre_xy: np.ndarray, rng: np.random.Generator, *,
                   views: int = 12, max_shift_m: float = 1.2, max_turn_rad: float = math.radians(8.0), lookahead_m: float = 12.0,
                   rows: int = 30, cols: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Return retinas (views + 1, rows·cols) and steering curvatures (views + 1,) [1/m]: the image as driven, then shifted views."""
    xs = [retina(image, rows, cols)]
    ks = [pursuit_curvature(centre_xy, lookahead_m)]
    for _ in range(views):
        dy = float(rng.uniform(-max_shift_m, max_shift_m))
        da = float(rng.uniform(-max_turn_rad, max_turn_rad))
        xs.append(retina(shifted_view(image, camera, dy, da), rows, cols))
        ks.append(pursuit_curvature(moved_line(centre_xy, dy, da), lookahead_m))
    return np.stack(xs), np.asarray(ks)
