"""The simulator's capture as PERCEPTION reads it: decode the `wire.capture` format (never truth) and
build the registered colored-range image (seed: Sidewalk 1986 §3.4.1; Navlab 1990 §2.3.1).

The capture is self-describing (extrinsics, intrinsics, ray angles), so nothing here imports the
simulator. The range is unwrapped past the ambiguity interval before the points are registered
into the camera, and the view is limited to one ambiguity interval of horizontal range.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from wire.capture import CaptureDecodeError, decode_capture

from modules.perception.errors import PerceptionError
from modules.perception.image import ColoredRangeImage
from modules.perception.patch_maker import unwrap_range
from modules.parallel import StripeOp, Stripe

if TYPE_CHECKING:
    from modules.parallel import VisionPool

__all__ = ["SensorFrameError", "SensorFrame", "decode_sensor_frame", "colored_range_image", "register_columns", "REGISTRATION",
           "sensor_geometry"]

_NEEDED = ("T_vehicle_laser", "T_vehicle_camera", "camera_K", "laser_az", "laser_el", "laser_range", "laser_valid", "camera_image")


class SensorFrameError(PerceptionError, ValueError):
    """A capture payload PERCEPTION cannot use; the message names the field and what is wrong."""


@dataclass(frozen=True)
class SensorFrame:
    """One capture: laser range (H, W) [m] wrapped, validity, ray angles [rad], camera image, calibration.

    `T_vehicle_laser`, `T_vehicle_camera` (4, 4) vehicle ← sensor; `camera_K` (3, 3); `stamp` [s] sim;
    `ambiguity` [m]. There is no field for truth: PERCEPTION sees what the sensors see.
    """

    stamp: float
    ambiguity: float
    T_vehicle_laser: np.ndarray
    T_vehicle_camera: np.ndarray
    camera_K: np.ndarray
    laser_az: np.ndarray
    laser_el: np.ndarray
    laser_range: np.ndarray
    laser_valid: np.ndarray
    camera_image: np.ndarray
    range_step: float = 0.08  # range quantum [m]

    @classmethod
    def from_fields(cls, obj: Any) -> "SensorFrame":
        """Build from any object with the capture's attribute names (e.g. a decoded `wire.capture.CaptureResult`)."""
        kw: dict[str, Any] = {"stamp": obj.stamp, "ambiguity": obj.ambiguity, "range_step": obj.range_step}
        for name in _NEEDED:
            v = getattr(obj, name, None)
            if v is None:
                raise SensorFrameError(f"capture: field {name!r} is missing (request both laser and camera)")
            kw[name] = v
        return cls(**kw)


def decode_sensor_frame(payload: bytes) -> SensorFrame:
    """Decode the simulator's capture bytes (`sidewalk.capture/1`); SensorFrameError names what is wrong."""
    try:
        return SensorFrame.from_fields(decode_capture(payload))
    except CaptureDecodeError as exc:
        raise SensorFrameError(str(exc)) from None


#: The last few ray geometries (ray angles and laser mount): a vehicle's scanner keeps one for every frame.
_RAYS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def _rays(frame: SensorFrame) -> tuple[np.ndarray, np.ndarray]:
    """Return the laser rays of a frame: unit directions (3, H, W) float64 in the vehicle frame, one row per
    axis, and where each meets the flat ground z = 0, (H, W, 2) float32 [m] vehicle frame (NaN above the horizon)."""
    az, el, T = frame.laser_az, frame.laser_el, np.asarray(frame.T_vehicle_laser)
    key = tuple((a.dtype.str, a.shape, a.tobytes()) for a in (az, el, T))
    if key in _RAYS:
        return _RAYS[key]
    az = az.astype(np.float64)
    el = el.astype(np.float64)
    ce = np.cos(el)[:, None]
    dirs = np.stack([ce * np.cos(az)[None, :], ce * np.sin(az)[None, :], np.broadcast_to(np.sin(el)[:, None], (len(el), len(az)))], axis=-1)
    R = T[:3, :3]
    t = T[:3, 3]
    dv = dirs @ R.T  # ray directions, vehicle frame
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(dv[..., 2] < -1e-3, -t[2] / dv[..., 2], np.nan)
    ground_xy = (t[:2] + s[..., None] * dv[..., :2]).astype(np.float32)
    if len(_RAYS) >= 4:
        _RAYS.pop(next(iter(_RAYS)))
    _RAYS[key] = (np.ascontiguousarray(np.moveaxis(dv, -1, 0)), ground_xy)
    return _RAYS[key]


def colored_range_image(frame: SensorFrame, max_horizontal: float | None = None, *, pool: "VisionPool | None" = None) -> ColoredRangeImage:
    """Unwrap the range, put the points in the vehicle frame and colour them from the camera (§3.4.1).

    Pixels count as valid when the laser returned, the point projects into the camera and its
    horizontal range is within `max_horizontal` [m] (default: one ambiguity interval). With a
    `pool` of several workers the laser columns are registered in vertical stripes (`REGISTRATION`).
    """
    if pool is not None and pool.workers > 1:
        h, w = frame.laser_range.shape
        got = pool.run(REGISTRATION,
                       {"laser_range": frame.laser_range, "laser_valid": frame.laser_valid, "laser_az": frame.laser_az,
                        "laser_el": frame.laser_el, "camera_image": frame.camera_image},
                       {"xyz": ((h, w, 3), np.float32), "ground_xy": ((h, w, 2), np.float32), "range_m": ((h, w), np.float32),
                        "valid": ((h, w), np.bool_), "rgb": ((h, w, 3), np.float32)},
                       (frame.stamp, frame.ambiguity, frame.T_vehicle_laser, frame.T_vehicle_camera, frame.camera_K, frame.range_step,
                        max_horizontal))
        return ColoredRangeImage(stamp=frame.stamp, **got)
    limit = frame.ambiguity if max_horizontal is None else max_horizontal
    dv, ground_xy = _rays(frame)
    t = frame.T_vehicle_laser[:3, 3]
    valid = frame.laser_valid.astype(bool)
    r = unwrap_range(frame.laser_range, valid, frame.ambiguity)
    xyz = np.empty(r.shape + (3,), dtype=np.float32)
    for k in range(3):
        xyz[..., k] = dv[k] * r + t[k]
    Tcv = np.linalg.inv(frame.T_vehicle_camera)
    pc = xyz.astype(np.float64) @ Tcv[:3, :3].T
    z = pc[..., 2] + Tcv[2, 3]
    K = frame.camera_K
    with np.errstate(divide="ignore", invalid="ignore"):
        u = K[0, 0] * (pc[..., 0] + Tcv[0, 3]) / z + K[0, 2]
        v = K[1, 1] * (pc[..., 1] + Tcv[1, 3]) / z + K[1, 2]
    h, w = frame.camera_image.shape[:2]
    horiz = np.hypot(xyz[..., 0] - t[0], xyz[..., 1] - t[1])
    ok = valid & (z > 0.1) & (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1) & (horiz <= limit)
    mx = np.where(ok, u, -1).astype(np.float32)
    my = np.where(ok, v, -1).astype(np.float32)
    rgb = cv2.remap(frame.camera_image.astype(np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    return ColoredRangeImage(xyz=xyz, ground_xy=ground_xy.copy(), range_m=r.astype(np.float32), valid=ok, rgb=rgb, stamp=frame.stamp)


def register_columns(arrays: dict[str, np.ndarray], params: tuple, stripe: Stripe) -> dict[str, np.ndarray]:
    """Register one stripe of laser columns: `colored_range_image` on the frame those columns make (a stripe operator)."""
    stamp, ambiguity, t_laser, t_camera, k, step, max_horizontal = params
    part = SensorFrame(stamp=stamp, ambiguity=ambiguity, T_vehicle_laser=t_laser, T_vehicle_camera=t_camera, camera_K=k,
                       laser_az=arrays["laser_az"], laser_el=arrays["laser_el"], laser_range=arrays["laser_range"],
                       laser_valid=arrays["laser_valid"], camera_image=arrays["camera_image"], range_step=step)
    img = colored_range_image(part, max_horizontal)
    return {"xyz": img.xyz, "ground_xy": img.ground_xy, "range_m": img.range_m, "valid": img.valid, "rgb": img.rgb}


#: Registration split into vertical stripes of laser columns: each column is unwrapped bottom-up and
#: every pixel registered on its own, so the stripes need no overlap (the camera image is read whole).
REGISTRATION = StripeOp(register_columns, overlap=0, axis=1,
                        axes={"laser_az": 0}, whole=frozenset({"laser_el", "camera_image"}))


def sensor_geometry(frame: SensorFrame) -> "SensorGeometry":
    """Return the laser geometry the capture describes (mount height, pitch, fields of view) for the view table."""
    from modules.perception.monitor import SensorGeometry

    el = frame.laser_el.astype(np.float64)
    az = frame.laser_az.astype(np.float64)
    rows, cols = len(el), len(az)
    vfov = float(abs(el[0] - el[-1]) * rows / max(rows - 1, 1))
    hfov = float(abs(az[0] - az[-1]) * cols / max(cols - 1, 1))
    t = frame.T_vehicle_laser[:3, 3]
    return SensorGeometry(height=float(t[2]), pitch_down=float(-np.mean(el)), hfov=hfov, vfov=vfov, rows=rows, cols=cols,
                          range_step=float(frame.range_step), x_offset=float(t[0]))
