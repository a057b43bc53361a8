"""The image pyramid (Navlab 1990 §4.3.2.1): seven levels of 2×2 averages, 512×512 down to 8×8.

Level 0 is the image; each next level replaces every 2×2 block by its mean (non-overlapping windows,
as the cluster-processor version did). Coordinates: pixel centres at integers, u right, v down; a
level-L coordinate x_L and its level-0 coordinate x_0 are related by x_0 = 2^L·(x_L + ½) − ½
(`to_level`, `from_level`).

Input partitioning: a pyramid of a horizontal stripe whose first row and height are multiples of
`stripe_alignment(levels)` is, level by level, the matching stripe of the whole image's pyramid,
bit for bit (each output pixel depends on its own 2×2 block only).
"""

from __future__ import annotations

import numpy as np

from modules.fido.errors import FidoError

__all__ = ["PYRAMID_LEVELS", "reduce", "build_pyramid", "stripe_alignment", "to_level", "from_level"]

#: The paper's pyramid: 512×512, 256×256, … 8×8.
PYRAMID_LEVELS = 7


def reduce(image: np.ndarray) -> np.ndarray:
    """Return the next pyramid level of `image` (H, W) float32: the mean of each 2×2 block, (H//2, W//2) float32."""
    im = np.asarray(image, np.float32)
    h, w = im.shape[0] // 2 * 2, im.shape[1] // 2 * 2
    a = im[0:h:2, 0:w:2]
    b = im[0:h:2, 1:w:2]
    c = im[1:h:2, 0:w:2]
    d = im[1:h:2, 1:w:2]
    return ((a + b) + (c + d)) * np.float32(0.25)


def build_pyramid(image: np.ndarray, levels: int = PYRAMID_LEVELS) -> tuple[np.ndarray, ...]:
    """Return the pyramid of a grey image (H, W): `levels` float32 arrays, level 0 the image itself.

    H and W must be multiples of 2^(levels−1) (512×512 gives the paper's seven levels down to 8×8).
    """
    im = np.asarray(image, np.float32)
    if im.ndim != 2:
        raise FidoError(f"pyramid: expected a grey image (H, W), got shape {im.shape}")
    k = stripe_alignment(levels)
    if im.shape[0] % k or im.shape[1] % k:
        raise FidoError(f"pyramid: {levels} levels need both image sides to be multiples of {k} px, got {im.shape}")
    out = [im]
    for _ in range(levels - 1):
        out.append(reduce(out[-1]))
    return tuple(out)


def stripe_alignment(levels: int = PYRAMID_LEVELS) -> int:
    """Return the row multiple [px] a stripe must start and end on to give the matching stripe of every level."""
    if levels < 1:
        raise FidoError(f"pyramid: levels must be ≥ 1, got {levels}")
    return 1 << (levels - 1)


def to_level(xy: np.ndarray, level: int) -> np.ndarray:
    """Return level-0 pixel coordinates (..., 2) as coordinates of pyramid level `level` (float64)."""
    s = float(1 << level)
    return (np.asarray(xy, np.float64) + 0.5) / s - 0.5


def from_level(xy: np.ndarray, level: int) -> np.ndarray:
    """Return coordinates (..., 2) of pyramid level `level` as level-0 pixel coordinates (float64)."""
    s = float(1 << level)
    return (np.asarray(xy, np.float64) + 0.5) * s - 0.5
