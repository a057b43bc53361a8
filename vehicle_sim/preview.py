"""Build the sensor preview the simulator node publishes on `sim/preview` for every capture it serves.

A preview is small and carries no truth: a downsampled camera image and the colored-range image
(camera colour registered on the laser pixels, drawn at square angles), JPEG-encoded with OpenCV.
"""

from __future__ import annotations

import cv2
import numpy as np

from vehicle_sim.render import colored_range_image, range_image
from wire.capture import CaptureResult
from wire.preview import PreviewImage, SimPreview

__all__ = ["make_preview", "PREVIEW_WIDTH"]

#: Width [px] of each preview image (height keeps the aspect ratio).
PREVIEW_WIDTH = 256
_LASER_ASPECT = 288 / 768  # the laser's 80°×30° field at square angles
_JPEG = [int(cv2.IMWRITE_JPEG_QUALITY), 70]


def _jpeg(rgb: np.ndarray, width: int, height: int) -> PreviewImage:
    """Return `rgb` (h, w, 3) uint8 resized to width×height [px] and JPEG-encoded."""
    small = cv2.resize(rgb, (width, height), interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(small, cv2.COLOR_RGB2BGR), _JPEG)
    if not ok:
        raise ValueError("JPEG encoding failed")
    return PreviewImage(format="jpeg", width=width, height=height, source_width=int(rgb.shape[1]),
                        source_height=int(rgb.shape[0]), data=buf.tobytes())


def make_preview(result: CaptureResult, seq: int = 0) -> SimPreview:
    """Return the preview of one capture: camera and colored-range (or false-colour range) images, no pose."""
    camera = None
    if result.camera_image is not None:
        h, w = result.camera_image.shape[:2]
        camera = _jpeg(result.camera_image, PREVIEW_WIDTH, max(1, round(PREVIEW_WIDTH * h / w)))
    cr = None
    lh = max(1, round(PREVIEW_WIDTH * _LASER_ASPECT))
    if result.colored_range is not None and result.colored_range_valid is not None:
        cr = _jpeg(colored_range_image(result.colored_range, result.colored_range_valid), PREVIEW_WIDTH, lh)
    elif result.laser_code is not None and result.laser_valid is not None:
        cr = _jpeg(range_image(result.laser_code, result.laser_valid), PREVIEW_WIDTH, lh)
    return SimPreview(stamp=float(result.stamp), vehicle=result.vehicle, camera=camera, colored_range=cr, seq=seq)
