"""Terrain vocabulary: tiles of the elevation map a terrain module built from the laser (seed: Navlab 1990 §2.3.3–2.4).

The terrain module posts one `terrain_tile` per square block of the world-frame elevation map it
changed; a newer tile of the same block (same `row0`, `col0`) replaces the older. The cells of every
tile lie on one lattice through the world origin: cell (i, j) covers x ∈ [j·resolution, (j+1)·resolution),
y ∈ [i·resolution, …) [m]. Heights travel as int16 centimetres (unknown: −32768), their standard
deviations as uint16 millimetres (unknown or larger: 65535), and the inadmissible cells (where no wheel
may stand: too steep or a discontinuity higher than the vehicle can climb) as a packed bit mask, each
base64 text, rows first (row 0 the southernmost).
"""

from __future__ import annotations

import base64
import binascii
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from modules.vocabulary._base import Frozen, finite, token_type

__all__ = ["TerrainTile", "UNKNOWN_CM", "MAX_SIGMA_MM"]

#: The height code of an unknown cell [cm].
UNKNOWN_CM = -32768
#: The sigma code of an unknown cell or one of 65.535 m or more [mm].
MAX_SIGMA_MM = 65535


def _decoded(text: str, what: str) -> bytes:
    try:
        return base64.b64decode(text.encode("ascii"), validate=True)
    except (binascii.Error, UnicodeEncodeError) as exc:
        raise ValueError(f"{what} is not base64 text: {exc}") from None


@token_type("terrain_tile")
class TerrainTile(Frozen):
    """One block of `ny` × `nx` cells of the elevation map from lattice cell (`row0`, `col0`), of `resolution` [m].

    `z_cm` int16 heights [cm], `sigma_mm` uint16 standard deviations [mm], `inadmissible` packed bits
    (numpy `packbits`, row-major), each base64; `sensed_at` [s] sim time of the newest image in it.
    """

    row0: int
    col0: int
    resolution: float = Field(gt=0.0)
    ny: int = Field(ge=1, le=1024)
    nx: int = Field(ge=1, le=1024)
    z_cm: str
    sigma_mm: str
    inadmissible: str
    sensed_at: finite
    frame: Literal["world"] = "world"

    @model_validator(mode="after")
    def _sizes(self) -> "TerrainTile":
        n = self.ny * self.nx
        for text, want, what in ((self.z_cm, 2 * n, "z_cm"), (self.sigma_mm, 2 * n, "sigma_mm"),
                                 (self.inadmissible, (n + 7) // 8, "inadmissible")):
            got = len(_decoded(text, what))
            if got != want:
                raise ValueError(f"{what} holds {got} bytes, a {self.ny}×{self.nx} tile needs {want}")
        return self

    @classmethod
    def encode(cls, row0: int, col0: int, resolution: float, z: np.ndarray, sigma: np.ndarray, inadmissible: np.ndarray,
               sensed_at: float) -> "TerrainTile":
        """Return the tile of heights `z` [m] (NaN unknown), `sigma` [m] and the bool mask `inadmissible`, each (ny, nx)."""
        z = np.asarray(z, np.float64)
        if z.ndim != 2 or np.shape(sigma) != z.shape or np.shape(inadmissible) != z.shape:
            raise ValueError(f"z {z.shape}, sigma {np.shape(sigma)} and inadmissible {np.shape(inadmissible)} must be one 2-D shape")
        known = np.isfinite(z)
        zc = np.full(z.shape, UNKNOWN_CM, np.int16)
        zc[known] = np.clip(np.round(z[known] * 100.0), UNKNOWN_CM + 1, 32767).astype(np.int16)
        s = np.asarray(sigma, np.float64)
        sm = np.full(z.shape, MAX_SIGMA_MM, np.uint16)
        ok = known & np.isfinite(s)
        sm[ok] = np.clip(np.round(s[ok] * 1000.0), 0, MAX_SIGMA_MM).astype(np.uint16)
        bits = np.packbits(np.asarray(inadmissible, bool).ravel())
        b64 = lambda a: base64.b64encode(a.astype(a.dtype.newbyteorder("<")).tobytes()).decode("ascii")  # noqa: E731
        return cls(row0=int(row0), col0=int(col0), resolution=float(resolution), ny=z.shape[0], nx=z.shape[1],
                   z_cm=b64(zc), sigma_mm=b64(sm), inadmissible=b64(bits), sensed_at=float(sensed_at))

    def heights(self) -> tuple[np.ndarray, np.ndarray]:
        """Return (z, sigma): (ny, nx) float32 heights [m] (NaN unknown) and standard deviations [m] (inf unknown)."""
        zc = np.frombuffer(_decoded(self.z_cm, "z_cm"), "<i2").reshape(self.ny, self.nx)
        sm = np.frombuffer(_decoded(self.sigma_mm, "sigma_mm"), "<u2").reshape(self.ny, self.nx)
        unknown = zc == UNKNOWN_CM
        z = np.where(unknown, np.nan, zc.astype(np.float32) / np.float32(100.0)).astype(np.float32)
        s = np.where(unknown | (sm == MAX_SIGMA_MM), np.inf, sm.astype(np.float32) / np.float32(1000.0)).astype(np.float32)
        return z, s

    def inadmissible_mask(self) -> np.ndarray:
        """Return the (ny, nx) bool mask of cells no wheel may stand on."""
        bits = np.frombuffer(_decoded(self.inadmissible, "inadmissible"), np.uint8)
        return np.unpackbits(bits, count=self.ny * self.nx).astype(bool).reshape(self.ny, self.nx)

    @property
    def origin(self) -> tuple[float, float]:
        """Return the lower-left corner (x, y) [m] of cell (0, 0) of the tile in `world`."""
        return (self.col0 * self.resolution, self.row0 * self.resolution)
