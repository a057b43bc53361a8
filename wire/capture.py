"""The capture format: what the simulator's `sim/capture` queryable is asked, and what it answers.

A capture is self-describing (it carries the extrinsics, intrinsics and ray angles), so a consumer
needs nothing from the simulator to use it; it travels as msgpack (`encode_capture` /
`decode_capture`, format `sidewalk.capture/1`). Frames: `vehicle` (x forward, y left, z up, origin on
the ground), `laser`, `camera` (optical).

Truth (`TRUTH_FIELDS`: the true pose and ground height, label images, true range, mixed-point flags,
the stereo pair's true depth)
travels only in replies on its own key, `sim/truth_capture` (so that access control can deny it: it
cannot see a payload's flag); only evaluation asks (the recorder, `sidewalk`'s evaluation commands,
tests). `sim/capture` never carries truth. PERCEPTION never asks and its decoder has no place for it.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any

import msgpack
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from wire.errors import PayloadError

__all__ = [
    "CaptureRequest", "CaptureResult", "CaptureDecodeError", "encode_capture", "decode_capture",
    "without_truth", "WIRE_FORMAT", "TRUTH_FIELDS",
]

WIRE_FORMAT = "sidewalk.capture/1"


class CaptureRequest(BaseModel):
    """What to capture: which sensors, the camera image size [px] (same field of view at any size), and the
    stereo pair's square image side [px] (a multiple of 64; the pair is off unless asked for)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    laser: bool = True
    camera: bool = True
    camera_width: int = Field(320, ge=16, le=2048)
    camera_height: int = Field(240, ge=16, le=2048)
    stereo: bool = False
    stereo_size: int = Field(512, ge=64, le=2048, multiple_of=64)
    #: ignored by the simulator (kept for old senders): truth comes only from the `sim/truth_capture` key
    truth: bool = False
    #: a capture of an earlier instant at most this old [s sim] will do: the newest the simulator still holds
    #: that has every part asked for (rendered for another asker), else one rendered now (issue 39)
    max_age_s: float = Field(0.0, ge=0.0, le=5.0)


class CaptureDecodeError(PayloadError, ValueError):
    """A capture payload that cannot be decoded; the message says which field and what is wrong."""


@dataclass(frozen=True)
class CaptureResult:
    """One stamped capture. Laser arrays are (64, 256) in scan order (row 0 = top, col 0 = left);
    camera arrays are (height, width) (row 0 = top). Fields that a request skipped are None.

    Calibration: `T_vehicle_laser`, `T_vehicle_camera` (4, 4) float64 homogeneous `vehicle ← sensor`;
    `camera_K` (3, 3) float64; `laser_az` (256,) / `laser_el` (64,) float32 pixel-centre angles [rad] in
    the laser frame (a laser pixel's ray is (cos el cos az, cos el sin az, sin el)); `range_step` [m],
    `ambiguity` [m].
    Laser: `laser_code` uint8 range code; `laser_range` float32 measured range [m] (= code × step,
    wrapped modulo `ambiguity`; 0 where invalid); `laser_valid` bool; `laser_reflectance` uint8;
    `laser_xyz` (64, 256, 3) float32 point of the measured range, vehicle frame [m] (NaN where invalid).
    `attitude` (2,) float32 [rad]: the vehicle's own inclinometer reading of its roll and pitch (REP-103) at
    the capture, with its error; present on rough ground (a world with terrain) only.
    Camera: `camera_image` (h, w, 3) uint8 RGB.
    Colored-range: `colored_range` (64, 256, 3) uint8 RGB, `colored_range_uv` (64, 256, 2) float32
    camera pixel (NaN = none), `colored_range_valid` bool.
    Stereo pair (only when asked for): `stereo_left`, `stereo_right` (n, n, 3) uint8 RGB; `stereo_K` (3, 3)
    float64, the intrinsics both cameras share; `T_vehicle_stereo_left`, `T_vehicle_stereo_right` (4, 4)
    float64 `vehicle ← camera` (optical frames; rectified: same rotation, the right camera along the left's +x).
    Truth (evaluation only; None unless the request asked for it): `truth_pose` (3,) float64 world (x [m], y [m], yaw [rad]); `truth_z` [m]
    ground under the vehicle; `laser_labels`, `camera_labels` uint8 class indices into
    `worldfile.KINDS` of the surface each ray meets ("sky" = nothing within 45 m for the laser,
    150 m for the camera; laser pixels beyond the 40 m maximum range keep their surface label but
    are not `laser_valid`); `laser_range_true` float32 true range [m] (inf = no return);
    `laser_mixed` bool (the pixel is a mixed point); `stereo_labels` (n, n) uint8 class of the left stereo
    image's pixels, `stereo_depth_true` (n, n) float32 true depth along the left camera's optical axis [m]
    (inf = sky, NaN = a depth edge inside the pixel); `truth_attitude` (2,) float64 the true roll and pitch [rad];
    `truth_world_laser` (4, 4) float64 the laser's true full 3-D pose, homogeneous `world ← laser`.
    """

    stamp: float
    vehicle: str
    range_step: float
    ambiguity: float
    T_vehicle_laser: np.ndarray
    T_vehicle_camera: np.ndarray
    camera_K: np.ndarray | None
    laser_az: np.ndarray
    laser_el: np.ndarray
    laser_code: np.ndarray | None = None
    laser_range: np.ndarray | None = None
    laser_valid: np.ndarray | None = None
    laser_reflectance: np.ndarray | None = None
    laser_xyz: np.ndarray | None = None
    laser_labels: np.ndarray | None = None
    laser_range_true: np.ndarray | None = None
    laser_mixed: np.ndarray | None = None
    camera_image: np.ndarray | None = None
    camera_labels: np.ndarray | None = None
    colored_range: np.ndarray | None = None
    colored_range_uv: np.ndarray | None = None
    colored_range_valid: np.ndarray | None = None
    truth_pose: np.ndarray | None = None
    truth_z: float | None = None
    stereo_K: np.ndarray | None = None
    T_vehicle_stereo_left: np.ndarray | None = None
    T_vehicle_stereo_right: np.ndarray | None = None
    stereo_left: np.ndarray | None = None
    stereo_right: np.ndarray | None = None
    stereo_labels: np.ndarray | None = None
    stereo_depth_true: np.ndarray | None = None
    attitude: np.ndarray | None = None
    truth_attitude: np.ndarray | None = None
    truth_world_laser: np.ndarray | None = None


#: The fields that are truth: sent only when the request asks for them.
TRUTH_FIELDS = ("truth_pose", "truth_z", "laser_labels", "camera_labels", "laser_range_true", "laser_mixed",
                "stereo_labels", "stereo_depth_true", "truth_attitude", "truth_world_laser")

_SCALARS = ("stamp", "vehicle", "truth_z", "range_step", "ambiguity")
_ARRAY_FIELDS = tuple(f.name for f in fields(CaptureResult) if f.name not in _SCALARS)
_DTYPES = {
    "truth_pose": "float64", "T_vehicle_laser": "float64", "T_vehicle_camera": "float64", "camera_K": "float64",
    "laser_az": "float32", "laser_el": "float32", "laser_code": "uint8", "laser_range": "float32",
    "laser_valid": "bool", "laser_reflectance": "uint8", "laser_xyz": "float32", "laser_labels": "uint8",
    "laser_range_true": "float32", "laser_mixed": "bool", "camera_image": "uint8", "camera_labels": "uint8",
    "colored_range": "uint8", "colored_range_uv": "float32", "colored_range_valid": "bool",
    "stereo_K": "float64", "T_vehicle_stereo_left": "float64", "T_vehicle_stereo_right": "float64",
    "stereo_left": "uint8", "stereo_right": "uint8", "stereo_labels": "uint8", "stereo_depth_true": "float32",
    "attitude": "float32", "truth_attitude": "float64", "truth_world_laser": "float64",
}


def without_truth(result: CaptureResult) -> CaptureResult:
    """Return the capture with every truth field removed."""
    return replace(result, **{name: None for name in TRUTH_FIELDS})


def encode_capture(result: CaptureResult, *, truth: bool = False) -> bytes:
    """Return the msgpack bytes of a capture (arrays as dtype, shape and raw little-endian bytes).

    Truth fields are written only with `truth=True`.
    """
    if not truth:
        result = without_truth(result)
    arrays = {}
    for name in _ARRAY_FIELDS:
        a = getattr(result, name)
        if a is None:
            continue
        a = np.ascontiguousarray(a, dtype=np.dtype(_DTYPES[name]).newbyteorder("<"))
        arrays[name] = {"dtype": _DTYPES[name], "shape": list(a.shape), "data": a.tobytes()}
    head: dict[str, Any] = {"format": WIRE_FORMAT, "stamp": result.stamp, "vehicle": result.vehicle,
                            "range_step": result.range_step, "ambiguity": result.ambiguity}
    if result.truth_z is not None:
        head["truth_z"] = result.truth_z
    head["arrays"] = arrays
    return msgpack.packb(head, use_bin_type=True)


def decode_capture(payload: bytes) -> CaptureResult:
    """Decode `encode_capture` bytes; raise `CaptureDecodeError` naming the bad field."""
    try:
        d = msgpack.unpackb(payload, raw=False)
    except Exception as exc:  # msgpack raises several unrelated types
        raise CaptureDecodeError(f"capture payload: not msgpack ({type(exc).__name__}: {exc})") from None
    if not isinstance(d, dict):
        raise CaptureDecodeError("capture payload: top level must be a map")
    if d.get("format") != WIRE_FORMAT:
        raise CaptureDecodeError(f"capture payload: format must be {WIRE_FORMAT!r}, got {d.get('format')!r}")
    out: dict[str, Any] = {}
    for key, typ in (("stamp", float), ("vehicle", str), ("truth_z", float), ("range_step", float), ("ambiguity", float)):
        v = d.get(key)
        if key == "truth_z" and v is None:
            continue
        if typ is float and isinstance(v, int) and not isinstance(v, bool):
            v = float(v)
        if not isinstance(v, typ):
            raise CaptureDecodeError(f"capture payload: field {key!r} must be {typ.__name__}, got {v!r}")
        out[key] = v
    arrays = d.get("arrays")
    if not isinstance(arrays, dict):
        raise CaptureDecodeError("capture payload: field 'arrays' must be a map")
    for name, spec in arrays.items():
        if name not in _DTYPES:
            raise CaptureDecodeError(f"capture payload: unknown array {name!r}")
        if not isinstance(spec, dict) or not isinstance(spec.get("data"), bytes) or not isinstance(spec.get("shape"), list):
            raise CaptureDecodeError(f"capture payload: array {name!r} needs dtype, shape (list) and data (bytes)")
        if spec.get("dtype") != _DTYPES[name]:
            raise CaptureDecodeError(f"capture payload: array {name!r} dtype must be {_DTYPES[name]}, got {spec.get('dtype')!r}")
        shape = spec["shape"]
        if not all(isinstance(n, int) and n >= 0 for n in shape):
            raise CaptureDecodeError(f"capture payload: array {name!r} has a bad shape {shape!r}")
        dt = np.dtype(_DTYPES[name]).newbyteorder("<")
        need = int(np.prod(shape, dtype=np.int64)) * dt.itemsize
        if len(spec["data"]) != need:
            raise CaptureDecodeError(f"capture payload: array {name!r} has {len(spec['data'])} bytes, shape {shape} needs {need}")
        out[name] = np.frombuffer(spec["data"], dtype=dt).reshape(shape).astype(np.dtype(_DTYPES[name]))
    for name in ("T_vehicle_laser", "T_vehicle_camera", "laser_az", "laser_el"):
        if name not in out:
            raise CaptureDecodeError(f"capture payload: required array {name!r} is missing")
    out.setdefault("camera_K", None)
    expect = {"truth_pose": (3,), "T_vehicle_laser": (4, 4), "T_vehicle_camera": (4, 4), "camera_K": (3, 3),
              "stereo_K": (3, 3), "T_vehicle_stereo_left": (4, 4), "T_vehicle_stereo_right": (4, 4), "attitude": (2,),
              "truth_attitude": (2,), "truth_world_laser": (4, 4)}
    for name, shp in expect.items():
        if out.get(name) is not None and out[name].shape != shp:
            raise CaptureDecodeError(f"capture payload: array {name!r} must have shape {shp}, got {out[name].shape}")
    lshape = (len(out["laser_el"]), len(out["laser_az"]))
    for name in ("laser_code", "laser_range", "laser_valid", "laser_reflectance", "laser_labels", "laser_range_true",
                 "laser_mixed", "colored_range_valid"):
        if name in out and out[name].shape != lshape:
            raise CaptureDecodeError(f"capture payload: array {name!r} must have shape {lshape}, got {out[name].shape}")
    for name, k in (("laser_xyz", 3), ("colored_range", 3), ("colored_range_uv", 2)):
        if name in out and out[name].shape != lshape + (k,):
            raise CaptureDecodeError(f"capture payload: array {name!r} must have shape {lshape + (k,)}, got {out[name].shape}")
    if "camera_image" in out:
        im = out["camera_image"]
        if im.ndim != 3 or im.shape[2] != 3:
            raise CaptureDecodeError(f"capture payload: array 'camera_image' must be (h, w, 3), got {im.shape}")
        if "camera_labels" in out and out["camera_labels"].shape != im.shape[:2]:
            raise CaptureDecodeError(f"capture payload: array 'camera_labels' must be {im.shape[:2]}, got {out['camera_labels'].shape}")
    _check_stereo(out)
    return CaptureResult(**out)


_STEREO_ARRAYS = ("stereo_K", "T_vehicle_stereo_left", "T_vehicle_stereo_right", "stereo_left", "stereo_right")


def _check_stereo(out: dict[str, Any]) -> None:
    """Raise `CaptureDecodeError` unless the stereo arrays are all there or all absent and their shapes agree."""
    have = [name for name in _STEREO_ARRAYS if name in out]
    if not have:
        for name in ("stereo_labels", "stereo_depth_true"):
            if name in out:
                raise CaptureDecodeError(f"capture payload: array {name!r} without the stereo images")
        return
    if len(have) != len(_STEREO_ARRAYS):
        missing = [name for name in _STEREO_ARRAYS if name not in out]
        raise CaptureDecodeError(f"capture payload: stereo arrays {missing} are missing")
    left = out["stereo_left"]
    if left.ndim != 3 or left.shape[2] != 3:
        raise CaptureDecodeError(f"capture payload: array 'stereo_left' must be (h, w, 3), got {left.shape}")
    if out["stereo_right"].shape != left.shape:
        raise CaptureDecodeError(f"capture payload: array 'stereo_right' must be {left.shape}, got {out['stereo_right'].shape}")
    for name in ("stereo_labels", "stereo_depth_true"):
        if name in out and out[name].shape != left.shape[:2]:
            raise CaptureDecodeError(f"capture payload: array {name!r} must be {left.shape[:2]}, got {out[name].shape}")
