"""YARF's local map (Navlab 1990 §5.6): paint evidence from many images in one ground frame.

"Intersections cover a large area compared to typical camera fields of view … the integration of
perception results from multiple images is necessary", and the map "gives the system a memory".
The map is a grid on the flat ground in the `map` frame — the vehicle frame of the first image,
carried forward by the odometry between images (the paper's common coordinate system; here the
follower's own, needing no position fixes). The grid rolls with the vehicle: when the point
`lead_m` ahead of it strays more than `recentre_m` from the grid's centre, the grid moves by whole
cells to centre there again, forgetting what falls off its far side. Each image adds, for every cell it sees within
`reach_m`, whether the pixel there looks like yellow paint (YARF's hue test) and whether it looks
like white paint (a blue value standing `white_contrast` DN above its neighbourhood's median, the
white-bar operator's cue); a cell's evidence is the share of the images that saw it which saw paint.
Cells never seen have no evidence (NaN). Grid arrays are (ny, nx), row j at y = y0 + (j + ½)·cell,
column i at x = x0 + (i + ½)·cell, (x0, y0) the grid's corner in the map frame [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from modules.road_following.camera import CameraGeometry
from modules.road_following.follower import VehicleMotion
from modules.road_following.yarf_trackers import yellow_mask

__all__ = ["LocalMapConfig", "LocalMap"]


@dataclass(frozen=True)
class LocalMapConfig:
    """The grid [m] in the map frame, the range an image paints [m] and the white-paint cue [DN, px]."""

    half_m: float = 40.0  # the grid spans ±this about its centre
    cell: float = 0.1
    lead_m: float = 15.0
    recentre_m: float = 10.0
    reach_m: float = 28.0
    near_m: float = 3.0  # nearer ground is under the bonnet or smeared across many pixels
    white_contrast: float = 35.0
    white_window_px: int = 15


class LocalMap:
    """The local map: `add` an image, `evidence` of yellow and white paint at map-frame points, `pose` of the vehicle in it."""

    def __init__(self, config: LocalMapConfig = LocalMapConfig()) -> None:
        """Start an empty map whose frame is the vehicle's at the first image."""
        c = config
        self.config = c
        self.nx = self.ny = 2 * int(round(c.half_m / c.cell))
        self.seen = np.zeros((self.ny, self.nx), np.float32)
        self.yellow = np.zeros((self.ny, self.nx), np.float32)
        self.white = np.zeros((self.ny, self.nx), np.float32)
        self.pose = np.zeros(3)  # the vehicle in the map frame: x, y [m], yaw [rad]
        self.x0, self.y0 = c.lead_m - c.half_m, -c.half_m  # the grid's corner in the map frame [m]
        off = (np.arange(self.nx) + 0.5) * c.cell
        self._ox, self._oy = np.meshgrid(off, off)  # cell centres relative to the corner

    def _recentre(self) -> None:
        """Move the grid by whole cells to centre on the point `lead_m` ahead of the vehicle when it strayed."""
        c = self.config
        x, y, yaw = self.pose
        tx, ty = x + c.lead_m * math.cos(yaw), y + c.lead_m * math.sin(yaw)
        di = int(round((tx - c.half_m - self.x0) / c.cell))
        dj = int(round((ty - c.half_m - self.y0) / c.cell))
        if math.hypot(di, dj) * c.cell <= c.recentre_m:
            return
        for a in (self.seen, self.yellow, self.white):
            moved = np.zeros_like(a)
            src = a[max(0, dj):self.ny + min(0, dj), max(0, di):self.nx + min(0, di)]
            moved[max(0, -dj):max(0, -dj) + src.shape[0], max(0, -di):max(0, -di) + src.shape[1]] = src
            a[...] = moved
        self.x0 += di * c.cell
        self.y0 += dj * c.cell

    def move(self, motion: VehicleMotion) -> None:
        """Carry the vehicle's pose in the map by the odometry since the last image."""
        x, y, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        self.pose = np.array([x + c * motion.dx - s * motion.dy, y + s * motion.dx + c * motion.dy, yaw + motion.dyaw])

    def to_vehicle(self, xy: np.ndarray) -> np.ndarray:
        """Map map-frame points (..., 2) into the current `vehicle` frame."""
        x, y, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        d = np.asarray(xy, float) - (x, y)
        return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)

    def to_map(self, xy: np.ndarray) -> np.ndarray:
        """Map current `vehicle` points (..., 2) into the map frame."""
        x, y, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        p = np.asarray(xy, float)
        return np.stack([x + c * p[..., 0] - s * p[..., 1], y + s * p[..., 0] + c * p[..., 1]], axis=-1)

    def add(self, image: np.ndarray, camera: CameraGeometry) -> None:
        """Paint this image's evidence (image (H, W, 3) uint8 of `camera`) into every cell it sees."""
        c = self.config
        self._recentre()
        x, y, _ = self.pose
        r = int(math.ceil(c.reach_m / c.cell))
        i0, i1 = max(0, int((x - self.x0) / c.cell) - r), min(self.nx, int((x - self.x0) / c.cell) + r + 1)
        j0, j1 = max(0, int((y - self.y0) / c.cell) - r), min(self.ny, int((y - self.y0) / c.cell) + r + 1)
        if i0 >= i1 or j0 >= j1:
            return
        win = np.s_[j0:j1, i0:i1]
        v = self.to_vehicle(np.stack([self.x0 + self._ox[win], self.y0 + self._oy[win]], axis=-1))
        dist = np.hypot(v[..., 0], v[..., 1])
        u, row, front = camera.project_ground(v)
        ok = front & (v[..., 0] > c.near_m) & (dist <= c.reach_m) & np.isfinite(u)
        ok &= (u >= 0) & (u <= camera.width - 1) & (row >= 0) & (row <= camera.height - 1)
        if not ok.any():
            return
        ui, vi = np.round(u[ok]).astype(int), np.round(row[ok]).astype(int)
        blue = np.ascontiguousarray(image[..., 2])
        bright = blue.astype(np.float32) - cv2.medianBlur(blue, c.white_window_px).astype(np.float32) > c.white_contrast
        self.seen[win][ok] += 1.0
        self.yellow[win][ok] += yellow_mask(image[vi, ui]).astype(np.float32)
        self.white[win][ok] += bright[vi, ui].astype(np.float32)

    def _cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        c = self.config
        i = np.floor((xy[..., 0] - self.x0) / c.cell).astype(int)
        j = np.floor((xy[..., 1] - self.y0) / c.cell).astype(int)
        inside = (i >= 0) & (i < self.nx) & (j >= 0) & (j < self.ny)
        return np.clip(i, 0, self.nx - 1), np.clip(j, 0, self.ny - 1), inside

    def evidence(self, xy: np.ndarray, kind: str) -> np.ndarray:
        """Return the share of the images that saw each map-frame point (..., 2) which saw `kind` ("yellow" or "white") paint; NaN: never seen."""
        i, j, inside = self._cells(np.asarray(xy, float))
        seen = np.where(inside, self.seen[j, i], 0.0)
        paint = (self.yellow if kind == "yellow" else self.white)[j, i]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(seen > 0, paint / np.maximum(seen, 1.0), np.nan)
