"""Terrain files: an elevation raster beside a world or map file (a compressed `.npz`), and the reference to it.

A world or map file may name one with its optional top-level `terrain` entry, `{"file": "NAME.npz"}`
(a path relative to the world file's directory). The raster holds heights on a regular grid of samples
in the `world` frame: sample (row i, column j) lies at (origin_x + j·resolution, origin_y + i·resolution)
[m], and the ground between samples is their bilinear interpolation; outside the raster the nearest
edge sample holds. Where a world has terrain, every height its objects' shapes give is above the
terrain (a flat cover at z = 0 lies on it; a tree's base z0 is above the terrain at its centre).

File layout (`numpy.savez_compressed`): `origin` (2,) float64 [m], `resolution` () float64 [m], and
either `z` (ny, nx) float32 [m], or `z` (ny, nx) int16 with `z_scale` () float64 [m per unit] (the
generator stores 5 mm units: small files, and the stored value is the truth).
"""

from __future__ import annotations

import io
import math
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, field_validator

from wire.errors import WireError

__all__ = ["TerrainRef", "TerrainRaster", "TerrainFileError", "load_terrain", "save_terrain", "quantise_terrain", "TERRAIN_QUANTUM"]

#: The height unit [m] `save_terrain` stores by default (int16, so heights within ±163 m).
TERRAIN_QUANTUM = 0.005
_MAX_SAMPLES = 64_000_000  # a raster larger than this is refused (256 MB of float32)


class TerrainFileError(WireError, ValueError):
    """A terrain file that cannot be used; the message names the file and what is wrong."""


class TerrainRef(BaseModel):
    """A world or map file's `terrain` entry: the raster file, relative to the world file's directory."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    file: str

    @field_validator("file")
    @classmethod
    def _npz(cls, v: str) -> str:
        if not v.endswith(".npz"):
            raise ValueError(f"must name a .npz file, got {v!r}")
        return v


@dataclass(frozen=True)
class TerrainRaster:
    """Ground heights `z` (ny, nx) float32 [m] at samples `resolution` [m] apart from (origin_x, origin_y) [m], world frame."""

    origin_x: float
    origin_y: float
    resolution: float
    z: np.ndarray

    def __post_init__(self) -> None:
        if not (self.resolution > 0.0 and math.isfinite(self.resolution)):
            raise TerrainFileError(f"terrain resolution must be a finite number > 0 m, not {self.resolution}")
        if self.z.ndim != 2 or min(self.z.shape) < 2:
            raise TerrainFileError(f"terrain heights must be a 2-D array of at least 2×2 samples, not shape {self.z.shape}")

    @property
    def shape(self) -> tuple[int, int]:
        """Return (ny, nx), the raster's rows and columns of samples."""
        return (int(self.z.shape[0]), int(self.z.shape[1]))

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """Return (xmin, ymin, xmax, ymax) [m] spanned by the samples."""
        ny, nx = self.shape
        return (self.origin_x, self.origin_y, self.origin_x + (nx - 1) * self.resolution,
                self.origin_y + (ny - 1) * self.resolution)

    def height(self, xy: np.ndarray) -> np.ndarray:
        """Return the bilinear ground height [m] at points `xy` (N, 2) [m] → (N,) float64 (edge samples hold outside)."""
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        ny, nx = self.shape
        u = np.clip((xy[:, 0] - self.origin_x) / self.resolution, 0.0, nx - 1.0)
        v = np.clip((xy[:, 1] - self.origin_y) / self.resolution, 0.0, ny - 1.0)
        j = np.minimum(u.astype(np.int64), nx - 2)
        i = np.minimum(v.astype(np.int64), ny - 2)
        fu, fv = u - j, v - i
        z = self.z
        z00, z01 = z[i, j].astype(np.float64), z[i, j + 1].astype(np.float64)
        z10, z11 = z[i + 1, j].astype(np.float64), z[i + 1, j + 1].astype(np.float64)
        return (z00 * (1 - fu) + z01 * fu) * (1 - fv) + (z10 * (1 - fu) + z11 * fu) * fv

    def height_at(self, x: float, y: float) -> float:
        """Return the bilinear ground height [m] at one point (x, y) [m] (scalar fast path of `height`)."""
        ny, nx = self.shape
        u = min(max((x - self.origin_x) / self.resolution, 0.0), nx - 1.0)
        v = min(max((y - self.origin_y) / self.resolution, 0.0), ny - 1.0)
        j, i = min(int(u), nx - 2), min(int(v), ny - 2)
        fu, fv = u - j, v - i
        z = self.z
        return float((z[i, j] * (1 - fu) + z[i, j + 1] * fu) * (1 - fv) + (z[i + 1, j] * (1 - fu) + z[i + 1, j + 1] * fu) * fv)


def load_terrain(path: str | Path) -> TerrainRaster:
    """Load and check a terrain file; raise `TerrainFileError` naming the file and what is wrong."""
    p = Path(path)
    try:
        with np.load(p, allow_pickle=False) as f:
            arrays = {k: f[k] for k in f.files}
    except FileNotFoundError:
        raise TerrainFileError(f"{p}: no such terrain file") from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise TerrainFileError(f"{p}: not a readable .npz file ({type(exc).__name__}: {exc})") from None
    for key in ("origin", "resolution", "z"):
        if key not in arrays:
            raise TerrainFileError(f"{p}: array {key!r} is missing (has {sorted(arrays)})")
    origin, res, z = arrays["origin"], arrays["resolution"], arrays["z"]
    if origin.shape != (2,) or not np.issubdtype(origin.dtype, np.floating) or not np.isfinite(origin).all():
        raise TerrainFileError(f"{p}: 'origin' must be 2 finite floats [m], got shape {origin.shape} dtype {origin.dtype}")
    if res.shape != () or not np.issubdtype(res.dtype, np.floating) or not (math.isfinite(float(res)) and float(res) > 0):
        raise TerrainFileError(f"{p}: 'resolution' must be one finite float > 0 [m], got {res!r}")
    if z.ndim != 2 or min(z.shape) < 2 or z.size > _MAX_SAMPLES:
        raise TerrainFileError(f"{p}: 'z' must be a 2-D array of 2×2 to {_MAX_SAMPLES} samples, got shape {z.shape}")
    if z.dtype == np.int16:
        scale = arrays.get("z_scale")
        if scale is None or scale.shape != () or not (math.isfinite(float(scale)) and float(scale) > 0):
            raise TerrainFileError(f"{p}: an int16 'z' needs 'z_scale', one finite float > 0 [m per unit]")
        heights = (z.astype(np.float32) * np.float32(scale)).astype(np.float32)
    elif z.dtype == np.float32:
        heights = z
        if not np.isfinite(heights).all():
            raise TerrainFileError(f"{p}: 'z' holds {int((~np.isfinite(heights)).sum())} non-finite heights")
    else:
        raise TerrainFileError(f"{p}: 'z' must be float32 or int16 (with 'z_scale'), got {z.dtype}")
    return TerrainRaster(float(origin[0]), float(origin[1]), float(res), np.ascontiguousarray(heights))


def quantise_terrain(raster: TerrainRaster, quantum: float = TERRAIN_QUANTUM) -> tuple[TerrainRaster, np.ndarray]:
    """Return `raster` as stored in `quantum` [m] units (what `load_terrain` reads back, bit for bit) and its int16 units."""
    units = np.rint(np.asarray(raster.z, np.float64) / quantum)
    if units.min() < -32767 or units.max() > 32767:
        raise TerrainFileError(f"heights {float(raster.z.min()):.1f}..{float(raster.z.max()):.1f} m do not fit int16 in {quantum} m units")
    zi = units.astype(np.int16)
    return TerrainRaster(raster.origin_x, raster.origin_y, raster.resolution,
                         (zi.astype(np.float32) * np.float32(quantum)).astype(np.float32)), zi


def save_terrain(path: str | Path, raster: TerrainRaster, *, quantum: float | None = TERRAIN_QUANTUM) -> TerrainRaster:
    """Write `raster` to `path` (int16 in `quantum` [m] units, or float32 with None); return the raster as stored.

    The returned raster is what `load_terrain` reads back, bit for bit (the stored heights are the truth).
    The file is byte-identical for identical rasters (no time stamps inside).
    """
    p = Path(path)
    arrays = {"origin": np.array([raster.origin_x, raster.origin_y], np.float64),
              "resolution": np.array(raster.resolution, np.float64)}
    if quantum is None:
        stored = TerrainRaster(raster.origin_x, raster.origin_y, raster.resolution, np.ascontiguousarray(raster.z, np.float32))
        arrays["z"] = stored.z
    else:
        try:
            stored, arrays["z"] = quantise_terrain(raster, quantum)
        except TerrainFileError as exc:
            raise TerrainFileError(f"{p}: {exc}") from None
        arrays["z_scale"] = np.array(quantum, np.float64)
    with zipfile.ZipFile(p, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, a in arrays.items():
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.require(a, requirements="C"), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            zf.writestr(info, buf.getvalue())
    return stored
