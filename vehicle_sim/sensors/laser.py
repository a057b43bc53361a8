"""An ERIM-like amplitude-modulated laser scanner: range and reflectance images (seed: Navlab §2.3.1).

256 × 64 pixels over 80° × 30°, scanned top to bottom. Range is the phase of the returned
modulation, so it is known only modulo the ambiguity interval (2^8 steps of 8 cm = 20.48 m) and is
reported as an 8-bit code. Noise grows with range and falls with the returned energy; at depth
discontinuities the footprint straddles two surfaces and the measured phase is that of the sum of
both returns (mixed points). Frames: rays are built in the `laser` frame (axes parallel to `vehicle`,
azimuth about the vehicle's vertical, elevation window centred on `tilt_deg`); a vehicle rolled or
pitched by rough ground tilts them, and each ray is then cast on its own (`Scene.cast_rays`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.scene import Hits, Scene
from vehicle_sim.sensors.extrinsics import world_from_vehicle

__all__ = [
    "LaserConfig",
    "LaserFrame",
    "laser_angles",
    "laser_directions",
    "range_sigma",
    "wrap_range",
    "quantise_range",
    "code_to_range",
    "mix_returns",
    "depth_edges",
    "scan",
]


class LaserConfig(BaseModel):
    """Scanner parameters: image size, field of view [deg], range coding [m], noise model."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    cols: int = Field(256, ge=8, le=2048)
    rows: int = Field(64, ge=4, le=1024)
    hfov_deg: float = Field(80.0, gt=0, lt=180)
    vfov_deg: float = Field(30.0, gt=0, lt=90)
    tilt_deg: float = Field(-14.0, ge=-60, le=30)  # elevation of the image centre [deg]
    range_step: float = Field(0.08, gt=0)  # [m] per code
    range_bits: int = Field(8, ge=4, le=16)
    max_range: float = Field(40.0, gt=0)  # no return beyond [m]
    sigma0: float = Field(0.015, ge=0)  # range noise floor [m]
    sigma_k: float = Field(0.00012, ge=0)  # noise growth: sigma = sigma0 + sigma_k r^2 / rho_eff [m]
    mixed_jump: float = Field(0.30, gt=0)  # depth edge threshold [m] (relative: also 3 % of range)
    mixed_probability: float = Field(0.8, ge=0, le=1)
    reflectance_noise: float = Field(3.0, ge=0)  # [DN]

    @property
    def ambiguity(self) -> float:
        """Return the ambiguity interval [m] (2^bits × step; 20.48 m for the ERIM)."""
        return self.range_step * (1 << self.range_bits)


@dataclass(frozen=True)
class LaserFrame:
    """One scan, arrays (rows, cols) in image order (row 0 = top, col 0 = left).

    `code` uint8/uint16 range code; `range` float32 measured range [m] (code × step, wrapped);
    `valid` bool (a return was received); `reflectance` uint8; `range_true` float32 true range [m]
    (inf = nothing; truth); `labels` uint8 class index into `worldfile.KINDS` (truth); `mixed` bool
    (truth: the pixel is a mixed point); `directions` float32 (rows, cols, 3) unit rays, laser frame.
    """

    code: np.ndarray
    range: np.ndarray
    valid: np.ndarray
    reflectance: np.ndarray
    range_true: np.ndarray
    labels: np.ndarray
    mixed: np.ndarray
    directions: np.ndarray


@lru_cache(maxsize=8)
def _angles(cfg: LaserConfig) -> tuple[np.ndarray, np.ndarray]:
    az = np.radians(cfg.hfov_deg * (0.5 - (np.arange(cfg.cols) + 0.5) / cfg.cols))
    el = np.radians(cfg.tilt_deg + cfg.vfov_deg * (0.5 - (np.arange(cfg.rows) + 0.5) / cfg.rows))
    az.setflags(write=False)
    el.setflags(write=False)
    return az, el


@lru_cache(maxsize=8)
def _directions(cfg: LaserConfig) -> np.ndarray:
    az, el = _angles(cfg)
    ce = np.cos(el)[:, None]
    d = np.stack([ce * np.cos(az)[None, :], ce * np.sin(az)[None, :],
                  np.broadcast_to(np.sin(el)[:, None], (len(el), len(az)))], axis=-1).astype(np.float32)
    d.setflags(write=False)
    return d


def laser_angles(cfg: LaserConfig) -> tuple[np.ndarray, np.ndarray]:
    """Return pixel-centre azimuths (cols,) and elevations (rows,) [rad], laser frame; left and top first."""
    az, el = _angles(cfg)
    return az.copy(), el.copy()


def laser_directions(cfg: LaserConfig) -> np.ndarray:
    """Return unit ray directions (rows, cols, 3) float32 in the laser frame (a read-only cached array)."""
    return _directions(cfg)


def range_sigma(r: np.ndarray, rho: np.ndarray, cfg: LaserConfig) -> np.ndarray:
    """Return the range noise standard deviation [m] at true range r [m] and effective reflectance rho [0–1]."""
    return cfg.sigma0 + cfg.sigma_k * np.square(r) / np.maximum(rho, 0.05)


def wrap_range(r: np.ndarray, ambiguity: float) -> np.ndarray:
    """Return range r [m] folded into the ambiguity interval [0, ambiguity)."""
    return np.mod(r, ambiguity)


def quantise_range(r: np.ndarray, cfg: LaserConfig) -> np.ndarray:
    """Return the range code of range r [m]: round(r / step) modulo 2^bits (wraps past the ambiguity interval)."""
    n = 1 << cfg.range_bits
    code = np.mod(np.rint(np.asarray(r, np.float64) / cfg.range_step).astype(np.int64), n)
    return code.astype(np.uint8 if cfg.range_bits <= 8 else np.uint16)


def code_to_range(code: np.ndarray, cfg: LaserConfig) -> np.ndarray:
    """Return the measured range [m] of a range code, float32."""
    return (code.astype(np.float32) * np.float32(cfg.range_step)).astype(np.float32)


def mix_returns(r1: np.ndarray, r2: np.ndarray, a1: np.ndarray, a2: np.ndarray, ambiguity: float) -> np.ndarray:
    """Return the range [m] measured from two superposed returns (phasor sum), in [0, ambiguity).

    r1, r2 true ranges [m]; a1, a2 returned amplitudes (≥ 0). Close ranges give a point between the
    two surfaces; the result is the phase of the summed modulation, not a plain average.
    """
    k = 2.0 * np.pi / ambiguity
    re = a1 * np.cos(k * r1) + a2 * np.cos(k * r2)
    im = a1 * np.sin(k * r1) + a2 * np.sin(k * r2)
    return np.mod(np.arctan2(im, re), 2.0 * np.pi) / k


def depth_edges(r: np.ndarray, cfg: LaserConfig) -> tuple[np.ndarray, np.ndarray]:
    """Return (edge, neighbour_index) for a true range image (rows, cols) [m] (inf = no return).

    A depth discontinuity between two 4-neighbours is a range step larger than max(mixed_jump,
    3 % of range) that is also 2.5× the steps on either side along the same line (so oblique but
    continuous ground is not an edge). `neighbour_index` is the flat index of the neighbour across
    the largest discontinuity (the pixel itself where there is none).
    """
    H, W = r.shape
    rr = np.where(np.isfinite(r), r, 1e4).astype(np.float64)
    idx = np.arange(H * W).reshape(H, W)
    best = np.zeros((H, W))
    nb = idx.copy()
    for axis in (0, 1):
        d = np.abs(np.diff(rr, axis=axis))  # step between k and k+1
        n = d.shape[axis]
        take = lambda a, sl: a[sl, :] if axis == 0 else a[:, sl]  # noqa: E731
        prev = np.concatenate([take(d, slice(0, 1)), take(d, slice(0, n - 1))], axis=axis)
        nxt = np.concatenate([take(d, slice(1, n)), take(d, slice(n - 1, n))], axis=axis)
        near = np.minimum(take(rr, slice(0, n)), take(rr, slice(1, n + 1)))
        thr = np.maximum(cfg.mixed_jump, 0.03 * np.minimum(near, 1e3))
        jump = (d > thr) & (d > 2.5 * np.minimum(prev, nxt))
        dj = np.where(jump, d, 0.0)
        for lo_side in (True, False):  # the pixel before the step, then the pixel after it
            if axis == 0:
                tgt = (slice(0, H - 1), slice(None)) if lo_side else (slice(1, H), slice(None))
                src = (slice(1, H), slice(None)) if lo_side else (slice(0, H - 1), slice(None))
            else:
                tgt = (slice(None), slice(0, W - 1)) if lo_side else (slice(None), slice(1, W))
                src = (slice(None), slice(1, W)) if lo_side else (slice(None), slice(0, W - 1))
            better = dj > best[tgt]
            best[tgt] = np.where(better, dj, best[tgt])
            nb[tgt] = np.where(better, idx[src], nb[tgt])
    edge = (best > 0) & np.isfinite(r)
    return edge, nb


def scan(scene: Scene, origin: np.ndarray, yaw: float, cfg: LaserConfig, rng: np.random.Generator,
         attitude: tuple[float, float] = (0.0, 0.0)) -> LaserFrame:
    """Scan the scene from the laser origin (3,) [m] (world frame) with the vehicle heading yaw [rad].

    `attitude` is the vehicle's (roll, pitch) [rad] (REP-103) on rough ground; level by default.
    """
    az, el = _angles(cfg)
    roll, pitch = (float(a) for a in attitude)
    tilted = roll != 0.0 or pitch != 0.0
    if tilted:
        R = world_from_vehicle(0.0, 0.0, yaw, 0.0, roll, pitch).R
        tilted_dirs = (laser_directions(cfg).astype(np.float64) @ R.T).astype(np.float32)
        hits: Hits = scene.cast_rays(origin, tilted_dirs)
    else:
        hits = scene.cast(origin, yaw + az, el)
    H, W = cfg.rows, cfg.cols
    r_true = hits.rng.astype(np.float64)
    in_range = hits.hit & (r_true <= cfg.max_range)
    r_true = np.where(in_range, r_true, np.inf)
    # effective reflectance: material reflectance × cos(incidence)
    dirs_l = laser_directions(cfg)
    c, s = math.cos(yaw), math.sin(yaw)
    if tilted:
        dirs_w = tilted_dirs
    else:
        dirs_w = np.stack([c * dirs_l[..., 0] - s * dirs_l[..., 1], s * dirs_l[..., 0] + c * dirs_l[..., 1], dirs_l[..., 2]], -1)
    cos_i = np.abs(np.sum(hits.normal * dirs_w, axis=-1))
    rho = scene.mat_refl[np.maximum(hits.material, 0)] * np.clip(cos_i, 0.05, 1.0)
    rho = np.where(in_range, rho, 0.0)
    amp = rho / np.square(np.maximum(np.where(in_range, r_true, 1.0), 1.0))
    # mixed points at depth discontinuities
    edge, nb = depth_edges(r_true, cfg)
    mixed = edge & in_range.ravel()[nb] & (rng.random((H, W)) < cfg.mixed_probability)
    w = rng.random((H, W))
    r_fin = np.where(in_range, r_true, 0.0)
    sel = np.nonzero(mixed)
    nb_sel = nb[sel]
    r_mix = r_fin.copy()
    r_mix[sel] = mix_returns(r_fin[sel], r_fin.ravel()[nb_sel], w[sel] * amp[sel], (1 - w[sel]) * amp.ravel()[nb_sel], cfg.ambiguity)
    # noise, then wrap and quantise
    sigma = range_sigma(np.where(in_range, r_true, 0.0), rho, cfg)
    noise = rng.standard_normal((H, W)) * sigma
    r_meas = np.where(mixed, r_mix, r_true) + noise
    valid = in_range
    code = quantise_range(np.where(valid, r_meas, 0.0), cfg)
    code = np.where(valid, code, 0).astype(code.dtype)
    rng_m = np.where(valid, code_to_range(code, cfg), 0.0).astype(np.float32)
    atten = 1.0 / (1.0 + np.square(np.where(in_range, r_true, 0.0) / 25.0))
    refl = 255.0 * np.clip(1.6 * rho * atten, 0.0, 1.0) + rng.standard_normal((H, W)) * cfg.reflectance_noise
    refl = np.where(valid, np.clip(np.rint(refl), 0, 255), 0).astype(np.uint8)
    return LaserFrame(
        code=code,
        range=rng_m,
        valid=valid,
        reflectance=refl,
        range_true=np.where(in_range, r_true, np.inf).astype(np.float32),
        labels=hits.label,
        mixed=mixed & valid,
        directions=dirs_l,
    )
