"""An ERIM range image as the terrain maps read it: ranges unwrapped, rays, the sensor's noise as the robot models it.

Navlab 1990 §2.3.1: 256 × 64 pixels, 8-bit range in 8 cm steps, so the range is known only within
the 20 m ambiguity interval. A column is unwrapped from its bottom row (the nearest ground) up:
where the range falls well below the last valid pixel beneath it (by more than a quarter of that
range, and 2 m), the interval is added from there on, if the sensor could have seen that far. Going
up a column over open ground the true range grows; what falls is a return from beyond the interval
(behind a crest the ground the rows above see can be 10 m farther, so a fall of half the interval
is not required). Above a gap (pixels without a return: their rays passed over everything within the
sensor's reach), a return is taken from beyond the interval whenever it can be: a ray above one that
met nothing within `max_range` passes over all the ground out there too, and only an overhang can
be nearer. An overhang (a crown above the ground seen under it) is then taken for far ground
and lands beyond the maps' reach, where it harms nothing; a ghost of far ground taken for near
ground would float above the map.

The noise model is the robot's own, calibrated as a sensor is: the range error grows with the square
of the range and falls with the energy returned, which the reflectance image measures: sigma =
`sigma0` + `k`·r² / reflectance [m] (reflectance in codes 0–255; `k` fitted to the spread of measured
against surveyed ranges over 80,000 returns of a cross-country scene, code steps included).
Frames: `laser` (the capture's; rays (cos el cos az, cos el sin az, sin el)), `vehicle` via the
capture's mount `T_vehicle_laser`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numba import njit

from modules.terrain.errors import TerrainError

__all__ = ["RangeNoise", "RangeImage", "unwrap_columns", "median_filter"]


@dataclass(frozen=True)
class RangeNoise:
    """The range noise the robot models [m]: sigma0 + k·r² / reflectance (codes, at least `dim`), quantisation included."""

    sigma0: float = 0.025
    k: float = 0.04
    dim: float = 2.0

    def sigma(self, r: np.ndarray, reflectance: np.ndarray) -> np.ndarray:
        """Return the range standard deviation [m] at ranges `r` [m] with reflectance codes `reflectance`, float32."""
        r = np.asarray(r, np.float32)
        q = np.maximum(np.asarray(reflectance, np.float32), np.float32(self.dim))
        return (np.float32(self.sigma0) + np.float32(self.k) * r * r / q).astype(np.float32)


@njit(cache=True, nogil=True, boundscheck=False)
def unwrap_columns(range_m: np.ndarray, valid: np.ndarray, ambiguity: float, max_range: float) -> np.ndarray:
    """Return the ranges (H, W) float32 [m] unwrapped column by column from the bottom row up (NaN where not valid);
    no range is taken beyond `max_range` [m], the farthest the sensor returns."""
    H, W = range_m.shape
    out = np.full((H, W), np.nan, np.float32)
    for j in range(W):
        offset = 0.0
        last = np.nan
        gap = False
        for i in range(H - 1, -1, -1):
            if not valid[i, j]:
                gap = last == last
                continue
            cur = range_m[i, j] + offset
            if last == last and (gap or cur < last - max(2.0, 0.25 * last)) and cur + ambiguity <= max_range:
                offset += ambiguity
                cur += ambiguity
            out[i, j] = cur
            last = cur
            gap = False
    return out


@njit(cache=True, nogil=True, boundscheck=False)
def median_filter(range_m: np.ndarray) -> np.ndarray:
    """Return the 3 × 3 median of the ranges (H, W) float32 [m] over the valid pixels of each window (NaN stays NaN).

    Navlab 1990 §2.3.1: most mixed points go; the noise falls to about half; a range step keeps its place.
    """
    H, W = range_m.shape
    out = np.full((H, W), np.nan, np.float32)
    buf = np.empty(9, np.float32)
    for i in range(H):
        for j in range(W):
            if not range_m[i, j] == range_m[i, j]:
                continue
            n = 0
            for a in range(max(i - 1, 0), min(i + 2, H)):
                for b in range(max(j - 1, 0), min(j + 2, W)):
                    v = range_m[a, b]
                    if v == v:
                        k = n
                        while k > 0 and buf[k - 1] > v:  # insertion into the sorted buffer
                            buf[k] = buf[k - 1]
                            k -= 1
                        buf[k] = v
                        n += 1
            out[i, j] = buf[n // 2] if n % 2 == 1 else np.float32(0.5) * (buf[n // 2 - 1] + buf[n // 2])
    return out


@lru_cache(maxsize=4)
def _directions(az_bytes: bytes, el_bytes: bytes) -> np.ndarray:
    """Return the unit rays (H, W, 3) float64 of float32 azimuths and elevations given as bytes [rad]."""
    az = np.frombuffer(az_bytes, np.float32).astype(np.float64)
    el = np.frombuffer(el_bytes, np.float32).astype(np.float64)
    ce = np.cos(el)[:, None]
    d = np.stack([ce * np.cos(az)[None, :], ce * np.sin(az)[None, :],
                  np.broadcast_to(np.sin(el)[:, None], (len(el), len(az)))], axis=-1)
    d.setflags(write=False)
    return d


@dataclass(frozen=True)
class RangeImage:
    """One range image: `range` (H, W) float32 [m] unwrapped (NaN = no return) and its `sigma` (H, W) float32 [m], ray
    angles `az` (W,), `el` (H,) [rad] (laser frame, left and top first), the mount `T_vehicle_laser` (4, 4), sim time
    `stamp` [s]."""

    range: np.ndarray
    sigma: np.ndarray
    az: np.ndarray
    el: np.ndarray
    T_vehicle_laser: np.ndarray
    stamp: float = 0.0

    def __post_init__(self) -> None:
        if self.range.shape != (len(self.el), len(self.az)) or self.sigma.shape != self.range.shape:
            raise TerrainError(f"a range image of shape {self.range.shape} needs {self.range.shape[0]} elevations and "
                               f"{self.range.shape[1]} azimuths and sigmas of its shape, got {len(self.el)}, {len(self.az)} "
                               f"and {self.sigma.shape}")

    @classmethod
    def from_capture(cls, capture: Any, noise: RangeNoise | None = None, max_range: float = 40.0, median: bool = True
                     ) -> "RangeImage":
        """Build from a capture (`wire.capture.CaptureResult` or anything with its laser fields): unwrap the ranges (the
        ERIM returns nothing beyond `max_range` [m], Navlab 1990 Table 2.1) and, with `median`, filter them 3 × 3
        (the sigmas then halve: the median of nine about halves the noise)."""
        for name in ("laser_range", "laser_valid", "laser_reflectance", "laser_az", "laser_el", "T_vehicle_laser"):
            if getattr(capture, name, None) is None:
                raise TerrainError(f"capture: field {name!r} is missing (ask for the laser)")
        valid = np.asarray(capture.laser_valid, bool)
        rng = unwrap_columns(np.asarray(capture.laser_range, np.float32), valid, float(capture.ambiguity), float(max_range))
        sigma = (noise or RangeNoise()).sigma(np.nan_to_num(rng, nan=0.0), capture.laser_reflectance)
        if median:
            rng, sigma = median_filter(rng), (np.float32(0.5) * sigma).astype(np.float32)
        return cls(rng, sigma, np.asarray(capture.laser_az, np.float32), np.asarray(capture.laser_el, np.float32),
                   np.asarray(capture.T_vehicle_laser, np.float64), float(capture.stamp))

    @property
    def valid(self) -> np.ndarray:
        """Return (H, W) bool: a return was received."""
        return np.isfinite(self.range)

    def directions(self) -> np.ndarray:
        """Return unit ray directions (H, W, 3) float64, laser frame (read-only; one array per ray geometry)."""
        return _directions(self.az.tobytes(), self.el.tobytes())

    def world_from_laser(self, world_from_vehicle: np.ndarray) -> np.ndarray:
        """Return world ← laser (4, 4) for a vehicle pose world ← vehicle (4, 4)."""
        return np.asarray(world_from_vehicle, np.float64) @ self.T_vehicle_laser
