"""The registered colored-range image every segmentation module reads (one common interface)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modules.perception.errors import PerceptionError

__all__ = ["ColoredRangeImage", "ImageError"]


class ImageError(PerceptionError, ValueError):
    """A colored-range image whose arrays disagree in shape or dtype."""


@dataclass(frozen=True)
class ColoredRangeImage:
    """Hold one registered colored-range frame on the laser grid, points in the vehicle frame.

    `xyz` (H, W, 3) float32 [m] laser points in the vehicle frame (x forward, y left, z up);
    `ground_xy` (H, W, 2) float32 [m] where each pixel's ray meets the flat ground z = 0
    (vehicle frame; NaN above the horizon) — what colour-only segmentation may use;
    `range_m` (H, W) float32 [m] unwrapped range; `valid` (H, W) bool: a laser return inside the
    view frame; `rgb` (H, W, 3) float32 registered colour (0–255); `stamp` [s] sim time.
    """

    xyz: np.ndarray
    ground_xy: np.ndarray
    range_m: np.ndarray
    valid: np.ndarray
    rgb: np.ndarray
    stamp: float = 0.0

    def __post_init__(self) -> None:
        h, w = self.valid.shape
        for name, arr, tail in (
            ("xyz", self.xyz, (3,)),
            ("ground_xy", self.ground_xy, (2,)),
            ("range_m", self.range_m, ()),
            ("rgb", self.rgb, (3,)),
        ):
            if arr.shape != (h, w, *tail):
                raise ImageError(f"ColoredRangeImage.{name}: shape {arr.shape}, expected {(h, w, *tail)}")
        if self.valid.dtype != bool:
            raise ImageError(f"ColoredRangeImage.valid: dtype {self.valid.dtype}, expected bool")

    @property
    def shape(self) -> tuple[int, int]:
        """Return (H, W) of the laser grid."""
        return self.valid.shape  # type: ignore[return-value]

    def subsample(self, step: int) -> "ColoredRangeImage":
        """Return every `step`-th row and column (a coarser resolution for the view-frame table)."""
        if step <= 1:
            return self
        s = np.s_[::step, ::step]
        return ColoredRangeImage(
            xyz=np.ascontiguousarray(self.xyz[s]),
            ground_xy=np.ascontiguousarray(self.ground_xy[s]),
            range_m=np.ascontiguousarray(self.range_m[s]),
            valid=np.ascontiguousarray(self.valid[s]),
            rgb=np.ascontiguousarray(self.rgb[s]),
            stamp=self.stamp,
        )
