"""Moravec's interest operator (Navlab 1990 §4.3.2.2): where a point can be found again in another image.

Around each pixel, the squared differences of neighbouring pixels are taken in a 3×3 window in four
directions (horizontal, vertical and both diagonals); the pixel's interest is the smallest of the
four, so only points whose intensity changes in every direction (corners) score high. We take each
direction's mean (six horizontal, six vertical and four pairs on each diagonal lie in the window),
so that the four are alike in scale. The interest values are then maximised in each of the 10×10
subimages of a regular grid, and the maxima are listed by decreasing interest: point features spread
over the whole image.

Input partitioning: `interest_map` of a stripe (rows or columns) carrying `INTEREST_HALO` pixels of
its neighbours on each side gives, inside that margin, the whole image's values bit for bit. The
selection (`select_features`) runs on the whole interest image, as the cluster processor did.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modules.fido.errors import FidoError

__all__ = ["INTEREST_HALO", "interest_map", "InterestPoints", "select_features"]

#: Pixels each stripe needs from its neighbours on each side (the 3×3 window's half-width).
INTEREST_HALO = 1


def interest_map(image: np.ndarray) -> np.ndarray:
    """Return the interest of every pixel of a grey image (H, W): (H, W) float32 [DN²], 0 on the one-pixel border."""
    im = np.asarray(image, np.float32)
    if im.ndim != 2 or im.shape[0] < 3 or im.shape[1] < 3:
        raise FidoError(f"interest operator: expected a grey image of at least 3×3, got shape {im.shape}")
    h, w = im.shape
    dh = np.square(im[:, 1:] - im[:, :-1])  # (H, W-1): pair (r, c)-(r, c+1)
    dv = np.square(im[1:, :] - im[:-1, :])  # (H-1, W): pair (r, c)-(r+1, c)
    dd = np.square(im[1:, 1:] - im[:-1, :-1])  # (H-1, W-1): pair (r, c)-(r+1, c+1)
    da = np.square(im[1:, :-1] - im[:-1, 1:])  # (H-1, W-1): pair (r, c+1)-(r+1, c)
    # window around (i, j), i in 1..H-2, j in 1..W-2, summed in a fixed order (stripes give the same bits)
    horiz = ((dh[:-2, :-1] + dh[:-2, 1:]) + (dh[1:-1, :-1] + dh[1:-1, 1:]) + (dh[2:, :-1] + dh[2:, 1:])) * np.float32(1 / 6)
    vert = ((dv[:-1, :-2] + dv[:-1, 1:-1] + dv[:-1, 2:]) + (dv[1:, :-2] + dv[1:, 1:-1] + dv[1:, 2:])) * np.float32(1 / 6)
    diag = ((dd[:-1, :-1] + dd[:-1, 1:]) + (dd[1:, :-1] + dd[1:, 1:])) * np.float32(0.25)
    anti = ((da[:-1, :-1] + da[:-1, 1:]) + (da[1:, :-1] + da[1:, 1:])) * np.float32(0.25)
    out = np.zeros((h, w), np.float32)
    out[1:-1, 1:-1] = np.minimum(np.minimum(horiz, vert), np.minimum(diag, anti))
    return out


@dataclass(frozen=True)
class InterestPoints:
    """Point features by decreasing interest: `uv` (N, 2) float64 pixel (u right, v down), `interest` (N,) float32 [DN²]."""

    uv: np.ndarray
    interest: np.ndarray


def select_features(interest: np.ndarray, grid: int = 10, min_interest: float = 0.0,
                    exclude: np.ndarray | None = None, min_separation: float = 0.0) -> InterestPoints:
    """Return the maximum of each subimage of a `grid`×`grid` partition of the interest image (H, W), by decreasing interest.

    A maximum counts when its interest exceeds `min_interest` [DN²]; with `exclude` (M, 2) pixels
    (features already known), a subimage's maximum within `min_separation` [px] of one is dropped.
    """
    iv = np.asarray(interest, np.float32)
    if iv.ndim != 2 or grid < 1 or iv.shape[0] < grid or iv.shape[1] < grid:
        raise FidoError(f"interest selection: a {grid}×{grid} grid does not fit an image of shape {iv.shape}")
    h, w = iv.shape
    rows = np.linspace(0, h, grid + 1).astype(int)
    cols = np.linspace(0, w, grid + 1).astype(int)
    uv, val = [], []
    for r0, r1 in zip(rows[:-1], rows[1:]):
        for c0, c1 in zip(cols[:-1], cols[1:]):
            sub = iv[r0:r1, c0:c1]
            k = int(np.argmax(sub))
            v = sub.flat[k]
            if v > min_interest:
                i, j = divmod(k, sub.shape[1])
                uv.append((c0 + j, r0 + i))
                val.append(v)
    pts = np.asarray(uv, np.float64).reshape(-1, 2)
    vals = np.asarray(val, np.float32)
    if exclude is not None and len(exclude) and len(pts) and min_separation > 0:
        ex = np.asarray(exclude, np.float64).reshape(-1, 2)
        d = np.min(np.linalg.norm(pts[:, None, :] - ex[None, :, :], axis=-1), axis=1)
        keep = d >= min_separation
        pts, vals = pts[keep], vals[keep]
    order = np.argsort(-vals, kind="stable")
    return InterestPoints(uv=pts[order], interest=vals[order])
