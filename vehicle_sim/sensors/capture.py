"""Capture both sensors at a vehicle pose: stamped images, registered colored-range, truth labels.

`capture` is the one call the simulator node (and the render/bench commands) make; the result
(`wire.capture.CaptureResult`, truth included) is self-describing, and the node sends it with
`wire.capture.encode_capture`, truth only when the request asks for it.
Frames: `vehicle` (x forward, y left, z up, origin on the ground), `laser`, `camera` (optical).
On rough ground (a scene with terrain) the vehicle rests on its wheels (`vehicle_sim.ground_contact`):
both sensors tilt with its roll and pitch, the capture carries the vehicle's inclinometer reading
(`attitude`, with its error) and, as truth, the true attitude and the laser's full 3-D pose.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from wire.capture import CaptureRequest, CaptureResult
from vehicle_sim.ground_contact import GroundPose, body_for, rest_on_ground
from vehicle_sim.scene import Scene
from vehicle_sim.sensors.camera import CameraConfig, camera_model, develop, expose
from vehicle_sim.sensors.extrinsics import extrinsics_for, world_from_vehicle
from vehicle_sim.sensors.laser import LaserConfig, laser_angles, scan
from vehicle_sim.sensors.registration import register

__all__ = [
    "capture",
    "warm_up",
]

_LASER_CFG = LaserConfig()
_CAMERA_BASE = CameraConfig()
_SIDE: tuple[int, ThreadPoolExecutor] | None = None
#: The inclinometer's error (one sigma) [rad] on roll and pitch: an INS-grade 0.1°, assumed (the seeds give none).
INCLINOMETER_SIGMA = math.radians(0.1)


def _side() -> ThreadPoolExecutor:
    """Return the one worker thread that renders the camera beside the laser (a new one in a forked child)."""
    global _SIDE
    if _SIDE is None or _SIDE[0] != os.getpid():
        _SIDE = (os.getpid(), ThreadPoolExecutor(max_workers=1, thread_name_prefix="camera-expose"))
    return _SIDE[1]


def capture(scene: Scene, pose_world: tuple[float, float, float], stamp: float,
            request: CaptureRequest = CaptureRequest(), *, vehicle: str = "navlab",
            rng: np.random.Generator | None = None, ground: GroundPose | None = None) -> CaptureResult:
    """Capture the requested sensors with the vehicle at `pose_world` (x [m], y [m], yaw [rad]) at sim time `stamp` [s].

    Sensor noise comes from `rng`; without one it is derived from the scene seed and the stamp, so
    the same seed, pose and stamp give the same frames. On rough ground the vehicle rests as `ground`
    says (the simulator's), or as `ground_contact.rest_on_ground` finds it on the scene.
    """
    x, y, yaw = (float(v) for v in pose_world)
    if not all(math.isfinite(v) for v in (x, y, yaw, float(stamp))):
        raise ValueError(f"capture: pose and stamp must be finite, got pose={pose_world!r} stamp={stamp!r}")
    ext = extrinsics_for(vehicle)
    if rng is None:
        rng = np.random.default_rng([scene.seed, 0xCA97, int(round(float(stamp) * 1e6)) & 0xFFFFFFFFFFFF])
    attitude = (0.0, 0.0)
    if scene.terrain is not None:
        ground = ground if ground is not None else rest_on_ground(scene.elevation, x, y, yaw, body_for(vehicle))
        z, attitude = ground.z, (ground.roll, ground.pitch)
    else:
        z = float(scene.elevation(np.array([[x, y]]))[0])
    w_v = world_from_vehicle(x, y, yaw, z, *attitude)
    laser_cfg = _LASER_CFG
    az, el = laser_angles(laser_cfg)
    cam_cfg = _CAMERA_BASE
    if (request.camera_width, request.camera_height) != (cam_cfg.width, cam_cfg.height):
        cam_cfg = cam_cfg.model_copy(update={"width": request.camera_width, "height": request.camera_height})
    model = camera_model(cam_cfg, ext.camera_pitch_deg)
    out: dict[str, Any] = dict(
        stamp=float(stamp), vehicle=vehicle, truth_pose=np.array([x, y, yaw]), truth_z=z,
        range_step=laser_cfg.range_step, ambiguity=laser_cfg.ambiguity,
        T_vehicle_laser=ext.vehicle_from_laser.matrix, T_vehicle_camera=ext.vehicle_from_camera.matrix,
        camera_K=model.K.copy(), laser_az=az.astype(np.float32), laser_el=el.astype(np.float32),
    )
    if scene.terrain is not None:  # the inclinometer draws from its own generator: the sensors' draws are unchanged
        tilt = np.random.default_rng([scene.seed, 0x1C71, int(round(float(stamp) * 1e6)) & 0xFFFFFFFFFFFF])
        out.update(attitude=(np.asarray(attitude) + tilt.normal(0.0, INCLINOMETER_SIGMA, 2)).astype(np.float32),
                   truth_attitude=np.asarray(attitude, np.float64),
                   truth_world_laser=w_v.compose(ext.vehicle_from_laser).matrix)
    lf = None
    cam_origin = w_v.apply(np.asarray(ext.camera_position))
    exposing = None
    if request.laser and request.camera:  # the camera renders on the side while the laser scans
        exposing = _side().submit(expose, scene, cam_origin, yaw, float(stamp), model, attitude)
    if request.laser:
        try:
            lf = scan(scene, w_v.apply(np.asarray(ext.laser_position)), yaw, laser_cfg, rng, attitude)
        except BaseException:
            if exposing is not None:
                exposing.exception()  # let the side render end before the error leaves
            raise
        xyz = lf.directions * lf.range[..., None] + np.asarray(ext.laser_position, np.float32)
        xyz[~lf.valid] = np.nan
        out.update(laser_code=lf.code, laser_range=lf.range, laser_valid=lf.valid, laser_reflectance=lf.reflectance,
                   laser_xyz=xyz.astype(np.float32), laser_labels=lf.labels, laser_range_true=lf.range_true,
                   laser_mixed=lf.mixed)
    if request.camera:
        # the laser draws from `rng` first, then the camera's noise: the same order as rendering one after the other
        exp = exposing.result() if exposing is not None else expose(scene, cam_origin, yaw, float(stamp), model, attitude)
        cf = develop(exp, model, rng)
        out.update(camera_image=cf.image, camera_labels=cf.labels)
        if lf is not None:
            cr = register(out["laser_xyz"], lf.valid, cf.image, ext.camera_from_vehicle, model.K)
            out.update(colored_range=cr.colour, colored_range_uv=cr.uv, colored_range_valid=cr.valid)
    return CaptureResult(**out)


def warm_up(scene: Scene, *, vehicle: str = "navlab") -> None:
    """Capture both sensors once at the world's start, so the ray caster's compiled kernels are built (seconds, the
    first time on a machine) or loaded from numba's on-disk cache (a quarter of a second) before anyone waits for a frame."""
    s = scene.world.start
    capture(scene, (s.x, s.y, s.yaw) if s is not None else (0.0, 0.0, 0.0), 0.0, vehicle=vehicle,
            rng=np.random.default_rng(0))
