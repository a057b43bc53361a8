"""Synthetic terrain scenes with known answers for the terrain libraries' tests: worlds in memory, captures and poses.

The scenes are rendered by the real simulator (terrain raster, ERIM scanner); the robot's side gets the capture
without truth, and the tests hand it the pose they choose (true or wrong on purpose).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import gaussian_filter

from modules.terrain.range_image import RangeImage
from modules.terrain.vehicle_pose import VehiclePose
from vehicle_sim.scene import Scene
from vehicle_sim.sensors.capture import capture
from vehicle_sim.worldfile import MapColour, PrismShape, StartPose, World, WorldObject
from wire.capture import CaptureRequest, CaptureResult, without_truth
from wire.terrainfile import TerrainRaster, TerrainRef

RES = 0.1
X0, Y0 = -10.0, -25.0
NY, NX = 501, 501  # 50 m × 50 m


def grid() -> tuple[np.ndarray, np.ndarray]:
    """Return the raster's sample coordinates X, Y (NY, NX) [m]."""
    ys, xs = np.meshgrid(Y0 + np.arange(NY) * RES, X0 + np.arange(NX) * RES, indexing="ij")
    return xs, ys


def terrain_world(z: np.ndarray, objects: tuple[WorldObject, ...] = ()) -> World:
    """Return a world in memory whose ground is the raster `z` (NY, NX) [m]."""
    raster = TerrainRaster(X0, Y0, RES, np.asarray(z, np.float32))
    return World(name="synthetic", objects=objects, start=StartPose(x=0.0, y=0.0, yaw_deg=0.0),
                 terrain=TerrainRef(file="synthetic.npz"), terrain_raster=raster)


def box(x0: float, y0: float, x1: float, y1: float, height: float) -> WorldObject:
    """Return a box standing on the terrain over [x0, x1] × [y0, y1] [m], `height` [m] tall."""
    return WorldObject(id="box", kind="building", role="obstacle", colour=MapColour(type="GRAY", nominal=(120.0, 120.0, 120.0)),
                       shape=PrismShape(height=height), polygon=((x0, y0), (x1, y0), (x1, y1), (x0, y1)))


def rough(seed: int = 4) -> np.ndarray:
    """Return rolling ground with rocks (NY, NX) [m]: relief that map matching can lock on to."""
    rng = np.random.default_rng(seed)
    z = gaussian_filter(rng.standard_normal((NY, NX)), 15)
    z = 0.6 * z / z.std()
    z += gaussian_filter(rng.standard_normal((NY, NX)), 3) * (0.05 / 0.1)
    xs, ys = grid()
    for _ in range(60):
        cx, cy, r = rng.uniform(0.0, 40.0), rng.uniform(-20.0, 20.0), rng.uniform(0.3, 0.9)
        z += 0.7 * r * np.sqrt(np.clip(1.0 - ((xs - cx) ** 2 + (ys - cy) ** 2) / r ** 2, 0.0, None))
    return z


def shoot(world: World, x: float, y: float, yaw: float, seed: int, scene: Scene | None = None
          ) -> tuple[CaptureResult, RangeImage, VehiclePose]:
    """Capture the laser at (x, y, yaw) [m, m, rad]; return the capture (truth in it), the robot's image, the true pose."""
    scene = scene if scene is not None else Scene(world, seed=0)
    cap = capture(scene, (x, y, yaw), float(seed), CaptureRequest(camera=False), vehicle="navlab",
                  rng=np.random.default_rng(seed))
    T = np.asarray(cap.truth_world_laser) @ np.linalg.inv(cap.T_vehicle_laser)
    pose = VehiclePose(x, y, float(T[2, 3]), float(cap.truth_attitude[0]), float(cap.truth_attitude[1]), yaw)
    return cap, RangeImage.from_capture(without_truth(cap)), pose


def centres(spec) -> tuple[np.ndarray, np.ndarray]:
    """Return the cell centres X, Y (ny, nx) [m] of a grid spec."""
    cx, cy = spec.centres()
    return np.meshgrid(cx, cy)


def deg(a: float) -> float:
    """Return `a` [rad] in degrees."""
    return math.degrees(a)
