"""SCARF's texture operator (Navlab 1990 §4.4.1, §4.4.2.1): brightness-independent texture from the blue pyramid.

The blue band is reduced into a pyramid of 2×2 averages: a fine level 4× the classified image, an
average level 2× and a coarse level 1× (the paper's 120×128, 60×64 and 30×32 for a 30×32 classified
image). Two Roberts operators give the fine and the coarse edge images,

    edge[i][j] = |in[i][j] − in[i+1][j+1]| + |in[i+1][j] − in[i][j+1]|,

and a fine pixel is textured when its edge, divided by α × the coarse edge above it plus (1 − α)
× the average brightness above it, exceeds a threshold: texture "independent of brightness and
scale" (α = 0.2, the paper's). The texture image counts the textured fine pixels of each 4×4
block, 0–16, one value per classified pixel — the classifier's fourth measurement. The paper gives
no threshold; 0.25 lies between the sunlit road's and the grass's typical ratio on our roads.
All images are (rows, cols) float32, row 0 at the top; the Roberts edge of the last row and
column (no neighbour below or right) is 0.
"""

from __future__ import annotations

import cv2
import numpy as np

from modules.road_following.errors import RoadFollowingError

__all__ = ["TEXTURE_ALPHA", "TEXTURE_THRESHOLD", "BluePyramid", "blue_pyramid", "roberts", "texture_image"]

TEXTURE_ALPHA = 0.2
TEXTURE_THRESHOLD = 0.25


class BluePyramid:
    """The blue band's fine (4·rows, 4·cols), average (2·rows, 2·cols) and coarse (rows, cols) levels, float32 [DN]."""

    __slots__ = ("fine", "average", "coarse")

    def __init__(self, fine: np.ndarray, average: np.ndarray, coarse: np.ndarray) -> None:
        """Hold the three levels."""
        self.fine, self.average, self.coarse = fine, average, coarse


def _halve(a: np.ndarray) -> np.ndarray:
    """Return the 2×2 averages of `a` (2h, 2w) float32: (h, w)."""
    return 0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2])


def blue_pyramid(image: np.ndarray, rows: int, cols: int) -> BluePyramid:
    """Return the blue pyramid of `image` (H, W, 3) uint8 RGB for a classified image of rows × cols [px].

    The fine level is the blue band area-averaged to (4·rows, 4·cols); each further level averages 2×2.
    """
    if image.ndim != 3 or image.shape[2] != 3:
        raise RoadFollowingError(f"texture: expected an (H, W, 3) image, got shape {image.shape}")
    fine = cv2.resize(np.ascontiguousarray(image[..., 2]), (4 * cols, 4 * rows), interpolation=cv2.INTER_AREA).astype(np.float32)
    average = _halve(fine)
    return BluePyramid(fine, average, _halve(average))


def roberts(a: np.ndarray) -> np.ndarray:
    """Return the Roberts edge image of `a` (h, w) float32 (see the module docstring)."""
    e = np.zeros_like(a)
    e[:-1, :-1] = np.abs(a[:-1, :-1] - a[1:, 1:]) + np.abs(a[1:, :-1] - a[:-1, 1:])
    return e


def texture_image(p: BluePyramid, alpha: float = TEXTURE_ALPHA, threshold: float = TEXTURE_THRESHOLD) -> np.ndarray:
    """Return the texture image (rows, cols) float32: per classified pixel the count (0–16) of textured fine pixels."""
    fine_edge = roberts(p.fine)
    coarse_edge = roberts(p.coarse)
    scale = alpha * np.repeat(np.repeat(coarse_edge, 4, 0), 4, 1) + (1.0 - alpha) * np.repeat(np.repeat(p.average, 2, 0), 2, 1)
    textured = (fine_edge > threshold * np.maximum(scale, 1.0)).astype(np.float32)  # a black pixel (0 DN) divides by 1
    r, c = p.coarse.shape
    return textured.reshape(r, 4, c, 4).sum(axis=(1, 3), dtype=np.float32)
