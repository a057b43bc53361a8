"""Range segmentation: ambiguity unwrapping, jump edges, surface normals and roughness, surface labels.

Seed: Sidewalk 1986 §3.4.2 (jump edges, surface normal, surface curvature; smooth vs rough regions) and
Navlab 1990 §2.3.1 (8-bit range in 8 cm steps, 20 m ambiguity interval, mixed points at depth edges).
Normals and roughness come from least-squares plane fits (PCA) over metric neighbourhoods of a vehicle-frame
cell grid, so the 8 cm range quantisation near the vehicle averages out instead of looking like steps.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import cv2
import numpy as np

__all__ = [
    "SurfaceType",
    "RangeSegParams",
    "SurfaceFeatures",
    "unwrap_range",
    "jump_edges",
    "surface_features",
    "surface_labels",
    "smooth_labels",
    "height_noise",
    "segment_range",
]


class SurfaceType(IntEnum):
    """Surface label of a range pixel (0 = no label: no return, jump edge or outside the view frame)."""

    NONE = 0
    FLAT = 1  # flat ground: normal within flat_max_deg of vertical, smooth
    TILTED = 2  # smooth but tilted: a slope
    ROUGH = 3  # rough or stepped: stairs, bushes
    VERTICAL = 4  # tall or vertical: walls, trunks, posts


@dataclass(frozen=True)
class RangeSegParams:
    """Thresholds of the range segmentation ([m], [deg])."""

    cell: float = 0.25  # grid cell [m]
    x_max: float = 22.0  # grid extent ahead [m] (vehicle frame)
    y_max: float = 18.0  # grid half width [m]
    x_min: float = -2.0
    min_points: int = 10  # points a plane fit needs
    min_spread: float = 0.2  # second-largest spread of a fit's points [m] (rejects a single scan line)
    scales: tuple[int, ...] = (3, 7, 11)  # plane-fit windows [cells]
    rough_scales: tuple[int, ...] = (3, 7)  # windows whose residual counts as roughness [cells]
    flat_max_deg: float = 4.0  # steeper than this is tilted [deg]
    vertical_min_deg: float = 50.0  # steeper than this is vertical [deg]
    rough_sigma: float = 0.03  # plane-fit residual above which a surface is rough [m]
    vertical_span: float = 0.5  # height span inside one cell above which it is vertical [m]
    smooth: int = 5  # majority filter window on the surface labels [px]
    jump_abs: float = 0.6  # range step that is a jump edge at any range [m]
    jump_rel: float = 0.15  # ... or this fraction of the range (grazing ground steps reach ~10 %)


@dataclass(frozen=True)
class SurfaceFeatures:
    """Per-pixel surface attributes: `normal` (H, W, 3) vehicle frame, `tilt_deg` (H, W), `sigma` (H, W) [m], `span` (H, W) [m]."""

    normal: np.ndarray
    tilt_deg: np.ndarray
    sigma: np.ndarray
    span: np.ndarray
    ok: np.ndarray  # (H, W) bool: features exist for this pixel


def unwrap_range(range_m: np.ndarray, valid: np.ndarray, interval: float = 20.0, drop: float = 10.0) -> np.ndarray:
    """Undo the ambiguity interval column by column from the bottom row up ([m]); (H, W) float32.

    Scanning up a column the true range rarely falls; a fall of more than `drop` [m] below the last
    valid lower pixel is a wrap, so `interval` is added from there on.
    """
    r = range_m.astype(np.float32).copy()
    h, w = r.shape
    offset = np.zeros(w, dtype=np.float32)
    last = np.full(w, np.nan, dtype=np.float32)
    for row in range(h - 1, -1, -1):
        v = valid[row]
        cur = r[row] + offset
        fell = v & np.isfinite(last) & (cur < last - drop)
        offset = offset + np.where(fell, interval, 0.0).astype(np.float32)
        cur = r[row] + offset
        r[row] = cur
        last = np.where(v, cur, last)
    return r


def jump_edges(range_m: np.ndarray, valid: np.ndarray, jump_abs: float = 0.6, jump_rel: float = 0.15) -> np.ndarray:
    """Mark pixels next to a range discontinuity (and isolated mixed points); (H, W) bool."""
    r = np.where(valid, range_m, np.nan).astype(np.float32)
    jump = np.zeros(r.shape, dtype=bool)
    for axis in (0, 1):
        a = r
        d = np.abs(np.diff(a, axis=axis))
        near = np.fmin(np.take(a, range(a.shape[axis] - 1), axis=axis), np.take(a, range(1, a.shape[axis]), axis=axis))
        big = d > np.maximum(jump_abs, jump_rel * near)
        big &= np.isfinite(d)
        if axis == 0:
            jump[:-1] |= big
            jump[1:] |= big
        else:
            jump[:, :-1] |= big
            jump[:, 1:] |= big
    return jump & valid


def _cell_index(xyz: np.ndarray, use: np.ndarray, p: RangeSegParams) -> tuple[np.ndarray, int, int]:
    nx = int(np.ceil((p.x_max - p.x_min) / p.cell))
    ny = int(np.ceil(2 * p.y_max / p.cell))
    ix = np.floor((xyz[..., 0] - p.x_min) / p.cell).astype(np.int64)
    iy = np.floor((xyz[..., 1] + p.y_max) / p.cell).astype(np.int64)
    inside = use & (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    flat = np.where(inside, ix * ny + iy, -1)
    return flat, nx, ny


def _fit(moments: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fit z = a x + b y + c from summed moments; return (unit normals (M, 3), residual std [m], minor xy spread [m])."""
    n, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz = moments
    nn = np.maximum(n, 1.0)
    mx, my, mz = sx / nn, sy / nn, sz / nn
    cxx = sxx / nn - mx * mx
    cxy = sxy / nn - mx * my
    cyy = syy / nn - my * my
    cxz = sxz / nn - mx * mz
    cyz = syz / nn - my * mz
    czz = szz / nn - mz * mz
    det = cxx * cyy - cxy * cxy
    safe = np.where(np.abs(det) > 1e-12, det, 1e-12)
    a = (cyy * cxz - cxy * cyz) / safe
    b = (cxx * cyz - cxy * cxz) / safe
    res = czz - a * cxz - b * cyz
    norm = np.sqrt(a * a + b * b + 1.0)
    normal = np.stack([-a / norm, -b / norm, 1.0 / norm], axis=-1)
    # minor eigenvalue of the 2x2 xy covariance: how far the points spread across their main line
    tr = cxx + cyy
    disc = np.sqrt(np.maximum(0.25 * (cxx - cyy) ** 2 + cxy * cxy, 0.0))
    minor = np.maximum(0.5 * tr - disc, 0.0)
    return normal, np.sqrt(np.maximum(res, 0.0)) / norm, np.sqrt(minor)


def height_noise(xyz: np.ndarray, use: np.ndarray, window: tuple[int, int] = (3, 9), clip: float = 0.3) -> np.ndarray:
    """Estimate each pixel's height noise variance [m²] from height differences along its scan row; (H, W).

    Neighbours in one row share the depression angle, so on ground, treads and slopes seen across
    their axis their true heights agree and the differences are range noise and quantisation.
    """
    z = xyz[..., 2].astype(np.float32)
    d = z[:, 1:] - z[:, :-1]
    ok = use[:, 1:] & use[:, :-1] & (np.abs(d) < clip)
    sq = np.zeros(z.shape, np.float32)
    cnt = np.zeros(z.shape, np.float32)
    sq[:, 1:] += np.where(ok, d * d, 0.0)
    cnt[:, 1:] += ok
    num = cv2.boxFilter(sq, -1, (window[1], window[0]), normalize=False, borderType=cv2.BORDER_CONSTANT)
    den = cv2.boxFilter(cnt, -1, (window[1], window[0]), normalize=False, borderType=cv2.BORDER_CONSTANT)
    return np.where(den > 0, 0.5 * num / np.maximum(den, 1.0), 0.0).astype(np.float32)


def surface_features(xyz: np.ndarray, use: np.ndarray, params: RangeSegParams = RangeSegParams(), noise_var: np.ndarray | None = None) -> SurfaceFeatures:
    """Fit planes over metric neighbourhoods: normal, tilt from vertical, residual and height span per pixel.

    With `noise_var` (H, W) [m²] the residual is corrected for measurement noise: roughness is the
    part of the plane-fit scatter the noise does not explain.
    """
    p = params
    h, w = use.shape
    flat, nx, ny = _cell_index(xyz, use, p)
    sel = flat >= 0
    idx = flat[sel]
    pts = xyz[sel].astype(np.float64)
    ncell = nx * ny
    x, y, z = pts[:, 0], pts[:, 1], pts[:, 2]
    zmax = np.full(ncell, -np.inf)
    zmin = np.full(ncell, np.inf)
    np.maximum.at(zmax, idx, z)
    np.minimum.at(zmin, idx, z)
    span_cell = np.where(np.isfinite(zmax), zmax - zmin, 0.0)
    # tall cells (walls, trunks, posts) stay out of the neighbours' plane fits
    surface_pt = span_cell[idx] <= p.vertical_span
    sidx = idx[surface_pt]
    xs, ys, zs = x[surface_pt], y[surface_pt], z[surface_pt]
    nv = noise_var[sel][surface_pt].astype(np.float64) if noise_var is not None else np.zeros(xs.shape)
    weights = (None, xs, ys, zs, xs * xs, xs * ys, xs * zs, ys * ys, ys * zs, zs * zs, nv)
    grids = [np.bincount(sidx, weights=wt, minlength=ncell).reshape(nx, ny).astype(np.float64) for wt in weights]

    # plane fits at several scales: normals from the finest well-spread fit, roughness the largest
    # residual over the scales that can see a step (a stair tread can be wider than the fine window)
    cand = np.flatnonzero(grids[0].reshape(-1) > 0)
    normal_c = np.zeros((ncell, 3))
    sigma_c = np.zeros(ncell)
    ok_c = np.zeros(ncell, dtype=bool)
    have_normal = np.zeros(cand.size, dtype=bool)
    sig_best = np.zeros(cand.size)
    for k in p.scales:
        box = [cv2.boxFilter(g, cv2.CV_64F, (k, k), normalize=False, borderType=cv2.BORDER_CONSTANT).reshape(-1)[cand] for g in grids]
        nrm, sig, spread = _fit(box[:10])
        sig = np.sqrt(np.maximum(sig * sig - box[10] / np.maximum(box[0], 1.0), 0.0))
        good = (box[0] >= p.min_points) & (spread >= p.min_spread)
        take = good & ~have_normal
        normal_c[cand[take]] = nrm[take]
        if k in p.rough_scales:
            sig_best = np.where(good, np.maximum(sig_best, sig), sig_best)
        else:
            sig_best = np.where(take, sig, sig_best)
        have_normal |= good
    sigma_c[cand] = sig_best
    ok_c[cand] = have_normal
    tall = np.flatnonzero(span_cell > p.vertical_span)
    ok_c[tall] = True  # labelled vertical by their height span

    normal = np.zeros((h, w, 3), dtype=np.float32)
    sigma = np.zeros((h, w), dtype=np.float32)
    span = np.zeros((h, w), dtype=np.float32)
    ok = np.zeros((h, w), dtype=bool)
    normal[sel] = normal_c[idx]
    sigma[sel] = sigma_c[idx]
    span[sel] = span_cell[idx]
    ok[sel] = ok_c[idx]
    tilt = np.degrees(np.arccos(np.clip(np.abs(normal[..., 2]), 0.0, 1.0))).astype(np.float32)
    return SurfaceFeatures(normal=normal, tilt_deg=tilt, sigma=sigma, span=span, ok=ok)


def surface_labels(f: SurfaceFeatures, params: RangeSegParams = RangeSegParams(), jumps: np.ndarray | None = None) -> np.ndarray:
    """Label each pixel flat / tilted / rough / vertical from its surface features; (H, W) uint8 SurfaceType."""
    p = params
    lab = np.full(f.ok.shape, SurfaceType.NONE, dtype=np.uint8)
    vertical = (f.span > p.vertical_span) | (f.tilt_deg >= p.vertical_min_deg)
    rough = ~vertical & (f.sigma > p.rough_sigma)
    smooth = ~vertical & ~rough
    lab[smooth & (f.tilt_deg < p.flat_max_deg)] = SurfaceType.FLAT
    lab[smooth & (f.tilt_deg >= p.flat_max_deg)] = SurfaceType.TILTED
    lab[rough] = SurfaceType.ROUGH
    lab[vertical] = SurfaceType.VERTICAL
    lab[~f.ok] = SurfaceType.NONE
    if jumps is not None:
        lab[jumps] = SurfaceType.NONE
    return lab


def smooth_labels(labels: np.ndarray, valid: np.ndarray, k: int = 5) -> np.ndarray:
    """Replace each valid pixel's surface label by the majority label of its k×k neighbourhood (fills holes)."""
    best = np.zeros(labels.shape, np.float32)
    out = np.zeros_like(labels)
    for s in range(1, len(SurfaceType)):
        votes = cv2.boxFilter((labels == s).astype(np.float32), -1, (k, k), normalize=False, borderType=cv2.BORDER_CONSTANT)
        better = votes > best
        out[better] = s
        best = np.maximum(best, votes)
    out[~valid] = SurfaceType.NONE
    return out


def segment_range(xyz: np.ndarray, range_m: np.ndarray, valid: np.ndarray, params: RangeSegParams = RangeSegParams()) -> tuple[np.ndarray, SurfaceFeatures]:
    """Run jump edges, plane fits and labelling on one range frame; (surface labels (H, W) uint8, features)."""
    jumps = jump_edges(range_m, valid, params.jump_abs, params.jump_rel)
    use = valid & ~jumps
    feats = surface_features(xyz, use, params, height_noise(xyz, use))
    labels = smooth_labels(surface_labels(feats, params), valid, params.smooth)
    labels[jumps] = SurfaceType.NONE  # depth edges keep patches at different depths apart
    return labels, feats
