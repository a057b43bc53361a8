"""A colour camera: pinhole projection, sun shadows, slow global illumination change, pixel noise.

The image is rendered by casting a level azimuth/elevation grid that covers the camera's field of
view (`Scene.cast`) and resampling it to the pinhole pixels with a fixed `cv2.remap` (on flat worlds
the vehicle stays level, so the map is computed once per camera; rolled and pitched on rough ground,
`tilted_view` computes the grid and the remap for that attitude). Frames: pixel rays in the `camera` optical
frame (x right, y down, z forward); `K` maps camera-frame points to pixels (u right, v down; pixel
centres at integer coordinates).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.scene import Scene

__all__ = ["CameraConfig", "CameraModel", "CameraFrame", "Exposure", "camera_model", "tilted_view", "illumination_gain", "shoot",
           "expose", "develop"]

#: Shadowed surfaces receive only skylight: a little bluer than sunlight (multiplies the ambient term).
_SKY_TINT = np.array([0.90, 0.96, 1.12], np.float32)


class CameraConfig(BaseModel):
    """Camera parameters: image size [px], horizontal field of view [deg], lighting and noise."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    width: int = Field(320, ge=16, le=2048)
    height: int = Field(240, ge=16, le=2048)
    hfov_deg: float = Field(80.0, gt=1, lt=150)
    ambient: float = Field(0.42, ge=0, le=1)  # shadowed / sunlit brightness ratio
    illumination_amplitude: float = Field(0.12, ge=0, lt=1)  # relative global gain swing
    illumination_period_s: float = Field(240.0, gt=0)  # [s] of sim time
    noise_sigma: float = Field(2.5, ge=0)  # [DN] per channel
    reach: float = Field(150.0, gt=0)  # farthest surface drawn [m] (ground beyond the scene's march: z = 0)
    grid_oversample: float = Field(0.8, gt=0.2, le=4.0)  # az/el grid density relative to the centre pixel


@dataclass(frozen=True)
class CameraModel:
    """A camera's fixed geometry: intrinsics `K` (3, 3), the level az/el grid and the remap to pixels."""

    config: CameraConfig
    pitch_deg: float
    K: np.ndarray
    grid_az: np.ndarray  # (Wg,) [rad] relative to the vehicle heading, left first
    grid_el: np.ndarray  # (Hg,) [rad], top first
    map_x: np.ndarray  # (height, width) float32 grid column of each pixel
    map_y: np.ndarray  # (height, width) float32 grid row of each pixel
    pixel_az: np.ndarray  # (height, width) float32 level-frame azimuth of each pixel ray [rad]
    pixel_el: np.ndarray  # (height, width) float32 level-frame elevation of each pixel ray [rad]


@lru_cache(maxsize=16)
def camera_model(config: CameraConfig, pitch_deg: float) -> CameraModel:
    """Return (cached) the geometry of a camera pitched down by `pitch_deg` [deg] on a level vehicle."""
    W, H = config.width, config.height
    f = 0.5 * W / math.tan(math.radians(config.hfov_deg) / 2)
    K = np.array([[f, 0.0, (W - 1) / 2], [0.0, f, (H - 1) / 2], [0.0, 0.0, 1.0]])
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    xc = (u - K[0, 2]) / f
    yc = (v - K[1, 2]) / f
    # optical (x right, y down, z fwd) → level vehicle axes (x fwd, y left, z up), then pitch down
    d = np.stack([np.ones_like(xc), -xc, -yc], -1)
    p = math.radians(pitch_deg)
    dx = d[..., 0] * math.cos(p) + d[..., 2] * math.sin(p)
    dz = -d[..., 0] * math.sin(p) + d[..., 2] * math.cos(p)
    dy = d[..., 1]
    az = np.arctan2(dy, dx)
    el = np.arctan2(dz, np.hypot(dx, dy))
    step = 1.0 / (f * config.grid_oversample)
    az_hi, az_lo = az.max() + step, az.min() - step
    el_hi, el_lo = el.max() + step, el.min() - step
    wg = int(math.ceil((az_hi - az_lo) / step)) + 1
    hg = int(math.ceil((el_hi - el_lo) / step)) + 1
    grid_az = az_hi - np.arange(wg) * step
    grid_el = el_hi - np.arange(hg) * step
    map_x = ((az_hi - az) / step).astype(np.float32)
    map_y = ((el_hi - el) / step).astype(np.float32)
    return CameraModel(config, float(pitch_deg), K, grid_az, grid_el, map_x, map_y,
                       az.astype(np.float32), el.astype(np.float32))


def tilted_view(model: CameraModel, roll: float, pitch: float) -> CameraModel:
    """Return the camera's geometry on a vehicle rolled and pitched by `roll`, `pitch` [rad] (REP-103): grid and remap.

    The pixel rays of `model` (level vehicle axes) are turned by Ry(pitch)·Rx(roll); the level az/el
    grid is widened to cover them at the same angular step.
    """
    az, el = model.pixel_az.astype(np.float64), model.pixel_el.astype(np.float64)
    d = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], -1)
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    R = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]]) @ np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    d = d @ R.T
    taz = np.arctan2(d[..., 1], d[..., 0])
    tel = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1]))
    step = float(model.grid_az[0] - model.grid_az[1])
    az_hi, az_lo = taz.max() + step, taz.min() - step
    el_hi, el_lo = tel.max() + step, tel.min() - step
    wg = int(math.ceil((az_hi - az_lo) / step)) + 1
    hg = int(math.ceil((el_hi - el_lo) / step)) + 1
    return CameraModel(model.config, model.pitch_deg, model.K, az_hi - np.arange(wg) * step, el_hi - np.arange(hg) * step,
                       ((az_hi - taz) / step).astype(np.float32), ((el_hi - tel) / step).astype(np.float32),
                       taz.astype(np.float32), tel.astype(np.float32))


@dataclass(frozen=True)
class CameraFrame:
    """One colour image: `image` (height, width, 3) uint8 RGB; `labels` (height, width) uint8 class
    indices into `worldfile.KINDS` (truth); `gain` the global illumination gain at capture."""

    image: np.ndarray
    labels: np.ndarray
    gain: float


def illumination_gain(stamp: float, config: CameraConfig) -> float:
    """Return the global illumination gain at sim time `stamp` [s] (slow sinusoid around 1)."""
    return 1.0 + config.illumination_amplitude * math.sin(2.0 * math.pi * stamp / config.illumination_period_s)


@lru_cache(maxsize=16)
def _noise_bank(height: int, width: int) -> np.ndarray:
    """Return a fixed bank of unit Gaussian pixel noise, (2·height, 2·width, 3) float32."""
    return np.random.default_rng(0x401C3).standard_normal((2 * height, 2 * width, 3), dtype=np.float32)


def _noise(model: CameraModel, rng: np.random.Generator) -> np.ndarray:
    """Return one frame of pixel noise [DN]: a window at a random offset and sign in the fixed bank."""
    cfg = model.config
    bank = _noise_bank(cfg.height, cfg.width)
    dy, dx, sign = rng.integers(0, cfg.height), rng.integers(0, cfg.width), rng.integers(0, 2) * 2 - 1
    return bank[dy:dy + cfg.height, dx:dx + cfg.width] * np.float32(sign * cfg.noise_sigma)


def _sky(el: np.ndarray) -> np.ndarray:
    t = np.clip(el / 0.6, 0.0, 1.0)[:, None]
    horizon = np.array([205.0, 218.0, 232.0], np.float32)
    zenith = np.array([110.0, 150.0, 215.0], np.float32)
    return (horizon * (1 - t) + zenith * t).astype(np.float32)


@dataclass(frozen=True)
class Exposure:
    """A camera image before its pixel noise: `light` (height, width, 3) float32 [DN], `labels`, `gain`."""

    light: np.ndarray
    labels: np.ndarray
    gain: float


def shoot(scene: Scene, origin: np.ndarray, yaw: float, stamp: float, model: CameraModel,
          rng: np.random.Generator, attitude: tuple[float, float] = (0.0, 0.0)) -> CameraFrame:
    """Render the camera image from the camera origin (3,) [m] (world) at vehicle heading yaw [rad], sim time stamp [s].

    `attitude` is the vehicle's (roll, pitch) [rad] on rough ground; level by default.
    """
    return develop(expose(scene, origin, yaw, stamp, model, attitude), model, rng)


def expose(scene: Scene, origin: np.ndarray, yaw: float, stamp: float, model: CameraModel,
           attitude: tuple[float, float] = (0.0, 0.0)) -> Exposure:
    """Render the noiseless image (see `shoot`); draws nothing from any generator, so it may run beside other work."""
    if attitude[0] != 0.0 or attitude[1] != 0.0:
        model = tilted_view(model, float(attitude[0]), float(attitude[1]))
    cfg = model.config
    hits = scene.cast(origin, yaw + model.grid_az, model.grid_el, reach=cfg.reach)
    alb = scene.albedo(hits, stamp)
    sun = scene.sun_factor(hits)
    amb = cfg.ambient * _SKY_TINT
    light = amb[None, None, :] + ((1.0 - cfg.ambient) * sun)[..., None]
    col = np.multiply(alb, light, out=alb)
    sky = np.broadcast_to(_sky(model.grid_el)[:, None, :], col.shape)
    np.copyto(col, sky, where=~hits.hit[..., None])
    gain = illumination_gain(stamp, cfg)
    col *= np.float32(gain)
    img = cv2.remap(col, model.map_x, model.map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    labels = cv2.remap(hits.label, model.map_x, model.map_y, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)
    return Exposure(light=img, labels=labels, gain=gain)


def develop(exposure: Exposure, model: CameraModel, rng: np.random.Generator) -> CameraFrame:
    """Add the pixel noise drawn from `rng` to an exposure (in place) and quantise it to the uint8 image."""
    img = exposure.light
    if model.config.noise_sigma > 0:
        img += _noise(model, rng)
    img = np.clip(img + 0.5, 0, 255).astype(np.uint8)
    return CameraFrame(image=img, labels=exposure.labels, gain=exposure.gain)
