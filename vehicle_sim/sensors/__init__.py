"""Sensors: an ERIM-like laser scanner, a colour camera, FIDO's stereo pair, extrinsics, registration, capture."""

from vehicle_sim.sensors.camera import CameraConfig, CameraFrame, CameraModel, camera_model, illumination_gain, shoot
from wire.capture import WIRE_FORMAT, CaptureDecodeError, CaptureRequest, CaptureResult, decode_capture, encode_capture
from vehicle_sim.sensors.capture import capture
from vehicle_sim.sensors.extrinsics import (VEHICLES, Extrinsics, Transform, extrinsics_for, vehicle_from_optical, vehicle_from_world,
                                            world_from_vehicle)
from vehicle_sim.sensors.laser import LaserConfig, LaserFrame, laser_angles, laser_directions, scan
from vehicle_sim.sensors.registration import ColoredRange, project, register
from vehicle_sim.sensors.stereo import StereoConfig, StereoFrames, StereoMount, shoot_stereo, stereo_model, stereo_mount_for

__all__ = [
    "CameraConfig", "CameraFrame", "CameraModel", "camera_model", "illumination_gain", "shoot",
    "WIRE_FORMAT", "CaptureDecodeError", "CaptureRequest", "CaptureResult", "capture", "decode_capture", "encode_capture",
    "VEHICLES", "Extrinsics", "Transform", "extrinsics_for", "vehicle_from_optical", "vehicle_from_world", "world_from_vehicle",
    "LaserConfig", "LaserFrame", "laser_angles", "laser_directions", "scan",
    "ColoredRange", "project", "register",
    "StereoConfig", "StereoFrames", "StereoMount", "shoot_stereo", "stereo_model", "stereo_mount_for",
]
