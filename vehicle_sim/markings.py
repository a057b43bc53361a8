"""Painted road markings (yellow centre lines, white edge stripes, solid or broken) as a fine paint raster.

The world file gives each road its `markings` (`wire.mapfile.Marking`: polyline, colour, width,
dashes). They are rasterised once, at `RES` [m] over the markings' bounding box, into paint codes
(0 none, 1 yellow, 2 white) with sub-cell precision; `PaintRaster.paint` lays the paint over the
albedo of the ground hits of road materials. A world without markings builds no raster, so its
images are exactly what they were before markings existed. Frame: `world` (x east, y north) [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from wire.mapfile import MARKING_COLOURS, Marking, WorldObject

__all__ = ["RES", "PAINT_COLOURS", "PaintRaster", "dash_pieces"]

#: Paint raster pitch [m] (a 10 cm stripe is 2–3 cells wide).
RES = 0.04
#: Paint under full sun: mean and std sRGB [0–255], in `MARKING_COLOURS` order (traffic yellow, white).
PAINT_COLOURS: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...] = (
    ((205.0, 160.0, 35.0), (9.0, 8.0, 6.0)),
    ((222.0, 222.0, 214.0), (7.0, 7.0, 7.0)),
)
_SHIFT = 3  # fixed-point bits for cv2.fillPoly


def dash_pieces(m: Marking) -> list[np.ndarray]:
    """Return the painted pieces of a marking, each an (N, 2) polyline [m] in `world` (one for a solid stripe)."""
    pts = np.asarray(m.line, np.float64)
    if m.dash is None:
        return [pts]
    on, off = m.dash
    seg = np.diff(pts, axis=0)
    ln = np.linalg.norm(seg, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(ln)])
    total = float(cum[-1])

    def at(s: float) -> np.ndarray:
        i = int(min(np.searchsorted(cum, s, side="right") - 1, len(seg) - 1))
        t = (s - cum[i]) / max(ln[i], 1e-12)
        return pts[i] + t * seg[i]

    out = []
    s = 0.0
    while s < total:
        e = min(s + on, total)
        inner = [pts[k] for k in range(len(pts)) if s < cum[k] < e]
        out.append(np.array([at(s), *inner, at(e)]))
        s += on + off
    return out


def _piece_polygon(line: np.ndarray, width: float) -> np.ndarray:
    """Return the outline (M, 2) [m] of a stripe of `width` [m] along `line` (flat ends, mitred joins)."""
    import shapely

    poly = shapely.LineString(line).buffer(width / 2.0, cap_style="flat", join_style="mitre", mitre_limit=3.0)
    return np.asarray(poly.exterior.coords, np.float64)[:-1]


@dataclass(frozen=True)
class PaintRaster:
    """Paint codes (H, W) uint8 over the markings' bounding box: 0 none, 1 + index into `MARKING_COLOURS`.

    `origin` (2,) [m] is the world position of cell (0, 0)'s corner; cells are `RES` [m] square.
    """

    codes: np.ndarray
    origin: np.ndarray

    @staticmethod
    def build(objects: tuple[WorldObject, ...] | list[WorldObject]) -> "PaintRaster | None":
        """Rasterise every marking of `objects`; None when no object carries markings."""
        pieces: list[tuple[np.ndarray, int]] = []
        for o in objects:
            for m in o.markings:
                code = 1 + MARKING_COLOURS.index(m.colour)
                pieces += [(_piece_polygon(p, m.width), code) for p in dash_pieces(m) if len(p) >= 2]
        if not pieces:
            return None
        allpts = np.vstack([p for p, _ in pieces])
        lo = np.floor(allpts.min(axis=0)) - 1.0
        hi = np.ceil(allpts.max(axis=0)) + 1.0
        w = int(math.ceil((hi[0] - lo[0]) / RES)) + 1
        h = int(math.ceil((hi[1] - lo[1]) / RES)) + 1
        codes = np.zeros((h, w), np.uint8)
        scale = (1 << _SHIFT) / RES
        for poly, code in pieces:
            q = np.round((poly - lo) * scale - 0.5 * (1 << _SHIFT)).astype(np.int32)
            cv2.fillPoly(codes, [q.reshape(-1, 1, 2)], code, lineType=cv2.LINE_8, shift=_SHIFT)
        return PaintRaster(codes=codes, origin=lo)

    def codes_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Return the paint code at world points x, y [m] (same shape; 0 outside the raster)."""
        h, w = self.codes.shape
        ix = np.floor((x - self.origin[0]) * (1.0 / RES)).astype(np.int64)
        iy = np.floor((y - self.origin[1]) * (1.0 / RES)).astype(np.int64)
        inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
        out = np.zeros(np.shape(x), np.uint8)
        out[inside] = self.codes[iy[inside], ix[inside]]
        return out

    def paint(self, col: np.ndarray, xyz: np.ndarray, painted_material: np.ndarray, noise: np.ndarray) -> None:
        """Lay paint over `col` (H, W, 3) in place where `painted_material` (H, W) bool and the hit `xyz` [m] is painted."""
        sel = np.nonzero(painted_material)
        if sel[0].size == 0:
            return
        code = self.codes_at(xyz[..., 0][sel], xyz[..., 1][sel])
        k = np.flatnonzero(code)
        if k.size == 0:
            return
        rows, cols = sel[0][k], sel[1][k]
        c = code[k].astype(np.int64) - 1
        mean = np.asarray([p[0] for p in PAINT_COLOURS], np.float32)[c]
        std = np.asarray([p[1] for p in PAINT_COLOURS], np.float32)[c]
        col[rows, cols] = mean + std * noise[rows, cols]
