"""PATCH MAKER output: patches (connected regions of one label) with their common patch data.

Seed: Sidewalk 1986 §3.2.1 — colour type, surface type and normal, boundary polygon, neighbours; the
same structure whichever segmentation module made it, so one OBJECT FINDER serves all of them.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np
from shapely.geometry import Polygon as ShapelyPolygon

from modules.perception.column_mean import column_mean

__all__ = ["Patch", "PatchSet", "make_patches"]


@dataclass(frozen=True, eq=False)
class Patch:
    """One segment: labels, normal (vehicle frame), boundary polygon (vehicle frame [m]) and neighbours.

    `edge_flags[i]` is True when boundary vertex i lies on a real object edge (beside another valid
    patch of another colour type, or surface for range-only patches), False when it lies on the
    border of the view frame or beside missing data; `boundary` / `boundary_flags` give the same
    along the whole outline, densely.
    """

    id: int
    label: int
    colour_type: str | None
    surface: int | None  # SurfaceType value, None for colour-only patches
    normal: tuple[float, float, float] | None
    polygon: tuple[tuple[float, float], ...]
    edge_flags: tuple[bool, ...]
    area_m2: float
    pixels: int
    centroid: tuple[float, float]
    height: float  # mean z of the patch [m] (0 for colour-only patches)
    neighbours: tuple[int, ...]
    boundary: np.ndarray | None = None  # (K, 2) [m] vehicle frame: every other outline pixel, in order
    boundary_flags: np.ndarray | None = None  # (K,) bool: that outline pixel is on a real object edge

    def shape(self) -> ShapelyPolygon:
        """Return the boundary as a shapely polygon (vehicle frame)."""
        return self._shape

    @cached_property
    def _shape(self) -> ShapelyPolygon:
        poly = ShapelyPolygon(self.polygon)
        return poly if poly.is_valid else poly.buffer(0)


@dataclass(frozen=True)
class PatchSet:
    """All patches of one frame and the (H, W) int32 patch-id image (0 = no patch)."""

    patches: tuple[Patch, ...]
    ids: np.ndarray

    def by_id(self, pid: int) -> Patch:
        """Return the patch with id `pid` (KeyError if absent)."""
        for p in self.patches:
            if p.id == pid:
                return p
        raise KeyError(pid)


def _distinct(values: np.ndarray) -> np.ndarray:
    """Return the sorted distinct values of an integer array (what np.unique returns; by counting when they are few and non-negative)."""
    if values.size and values.min() >= 0 and values.max() <= 4 * values.size + 1024:
        return np.flatnonzero(np.bincount(values.reshape(-1)))
    return np.unique(values)


def _neighbour_pairs(ids: np.ndarray, reach: int = 2) -> set[tuple[int, int]]:
    h, w = ids.shape
    some = ids > 0
    codes = []
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        for k in range(1, reach + 1):
            sy, sx = dy * k, dx * k
            if sx >= 0:
                ab = np.s_[: h - sy, : w - sx], np.s_[sy:, sx:]
            else:
                ab = np.s_[: h - sy, -sx:], np.s_[sy:, : w + sx]
            a, b = ids[ab[0]], ids[ab[1]]
            m = (a != b) & some[ab[0]] & some[ab[1]]
            if m.any():
                lo = np.minimum(a[m], b[m]).astype(np.int64)
                hi = np.maximum(a[m], b[m]).astype(np.int64)
                codes.append(lo * (1 << 31) + hi)
    if not codes:
        return set()
    return {(code >> 31, code & ((1 << 31) - 1)) for code in np.unique(np.concatenate(codes)).tolist()}


def _absorb_specks(ids: np.ndarray, usable: np.ndarray, max_pixels: int, share: float = 0.6) -> set[int]:
    """Give each speck of usable, patchless pixels (≤ `max_pixels`) to the patch holding at least `share` of
    its border (8-neighbours), in place; return the ids of the patches grown."""
    free = ((ids == 0) & usable).astype(np.uint8)
    n, cc, stats, _ = cv2.connectedComponentsWithStats(free, connectivity=4)
    small = np.zeros(n, bool)
    small[1:] = stats[1:, cv2.CC_STAT_AREA] <= max_pixels
    if not small.any():
        return set()
    speck = np.where(small[cc], cc, 0)
    h, w = ids.shape
    pad = np.zeros((h + 2, w + 2), ids.dtype)
    pad[1:-1, 1:-1] = ids
    pad = pad.reshape(-1)
    at = np.flatnonzero(speck)  # the speck pixels, raster order
    of = speck.reshape(-1)[at]
    at = at + 2 * (at // w) + w + 3  # the same pixels in the padded image
    owners, around = [], []
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy == 0 and dx == 0:
                continue
            nb = pad[at + dy * (w + 2) + dx]
            sel = nb > 0
            owners.append(of[sel])
            around.append(nb[sel])
    sp = np.concatenate(owners).astype(np.int64)
    if sp.size == 0:
        return set()
    top = int(ids.max()) + 1
    key, count = np.unique(sp * top + np.concatenate(around), return_counts=True)
    sp, pid = key // top, key % top
    total = np.bincount(sp, weights=count, minlength=n)
    order = np.lexsort((-count, sp))
    first = order[np.concatenate([[True], np.diff(sp[order]) != 0])]
    won = first[count[first] >= share * total[sp[first]]]
    lut = np.zeros(n, ids.dtype)
    lut[sp[won]] = pid[won]
    gain = lut[speck]
    np.copyto(ids, gain, where=gain > 0)
    return {int(v) for v in pid[won]}


def make_patches(
    labels: np.ndarray,
    xy: np.ndarray,
    valid: np.ndarray,
    *,
    colour_of: dict[int, str] | None = None,
    surface_of: dict[int, int] | None = None,
    normals: np.ndarray | None = None,
    z: np.ndarray | None = None,
    min_area_m2: float = 0.2,
    min_pixels: int = 6,
    speck_pixels: int = 30,
) -> PatchSet:
    """Split a label image (H, W) int into connected patches with polygons in the vehicle frame.

    `xy` (H, W, 2) [m] vehicle-frame ground position of each pixel; `valid` (H, W) bool pixels with
    data; `colour_of` / `surface_of` map a label to its colour type / SurfaceType; `normals`
    (H, W, 3) and `z` (H, W) give patch normals and heights when range exists. Specks of at most
    `speck_pixels` pixels that belong to no patch (a few leaves, a rejected colour, a segment below
    the minimum area) join the one patch all around them.
    """
    h, w = labels.shape
    ids = np.zeros((h, w), dtype=np.int32)
    found: list[dict] = []
    next_id = 1
    good_xy = np.isfinite(xy[..., 0]) & np.isfinite(xy[..., 1]) & valid
    for lab in _distinct(labels[good_xy]):
        if lab <= 0:
            continue
        mask = ((labels == lab) & good_xy).astype(np.uint8)
        n, cc, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=4)
        for c in range(1, n):
            if stats[c, cv2.CC_STAT_AREA] < min_pixels:
                continue
            # the component's bounding box and a pixel around it: all that the outline and the pixel statistics read
            x0, y0 = stats[c, cv2.CC_STAT_LEFT], stats[c, cv2.CC_STAT_TOP]
            box = (slice(max(y0 - 1, 0), min(y0 + stats[c, cv2.CC_STAT_HEIGHT] + 1, h)),
                   slice(max(x0 - 1, 0), min(x0 + stats[c, cv2.CC_STAT_WIDTH] + 1, w)))
            m = cc[box] == c
            contours, _ = cv2.findContours(m.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE,
                                           offset=(box[1].start, box[0].start))
            if not contours:
                continue
            cont = max(contours, key=len)
            approx = cv2.approxPolyDP(cont, 1.0, True).reshape(-1, 2)
            if len(approx) < 3:
                continue
            pts = xy[approx[:, 1], approx[:, 0]].astype(np.float64)
            poly = ShapelyPolygon(pts)
            if not poly.is_valid:
                poly = poly.buffer(0)
                if poly.geom_type == "MultiPolygon":
                    poly = max(poly.geoms, key=lambda g: g.area)
            if poly.is_empty or poly.area < min_area_m2:
                continue
            found.append(dict(label=int(lab), box=box, mask=m, approx=approx, poly=poly, pts=pts, contour=cont.reshape(-1, 2)[::2]))
    for f in found:
        ids[f["box"]][f["mask"]] = next_id
        f["id"] = next_id
        next_id += 1
    if speck_pixels > 0 and found:
        for pid in _absorb_specks(ids, good_xy, speck_pixels):
            f = found[pid - 1]
            f["box"] = np.s_[:, :]
            f["mask"] = ids == pid
    pairs = _neighbour_pairs(ids)
    nb: dict[int, set[int]] = {f["id"]: set() for f in found}
    for a, b in pairs:
        nb[a].add(b)
        nb[b].add(a)
    # a real object edge is sharp where the colour type changes (colour boundaries are pixel-exact;
    # boundaries that only the surface label draws are smeared by the plane-fit window)
    present = _distinct(labels)
    if colour_of:
        key = {lab: colour_of.get(lab) for lab in present.tolist()}
    else:
        key = {lab: (surface_of or {}).get(lab, lab) for lab in present.tolist()}
    keys = sorted({str(v) for v in key.values()})
    # pixels no class claimed (rejected colours, shadows) tell nothing: -1
    if present.size and present[0] >= 0:
        lut = np.full(int(present[-1]) + 1, -1, np.int32)
        for lab, v in key.items():
            if lab > 0:
                lut[lab] = keys.index(str(v))
        key_img = lut[labels]
    else:
        key_img = np.full(labels.shape, -1, np.int32)
        for lab, v in key.items():
            if lab > 0:
                key_img[labels == lab] = keys.index(str(v))
    key_img[~valid] = -1
    # per pixel: every 5x5 neighbour has data, and some neighbour has another colour type (or surface)
    ker = np.ones((5, 5), np.uint8)
    all_valid = cv2.erode(valid.astype(np.uint8), ker, borderType=cv2.BORDER_CONSTANT, borderValue=0).astype(bool)
    kmax = cv2.dilate(key_img.astype(np.float32), ker, borderType=cv2.BORDER_CONSTANT, borderValue=-1)
    kmin = cv2.erode(np.where(key_img >= 0, key_img, 1 << 20).astype(np.float32), ker, borderType=cv2.BORDER_CONSTANT, borderValue=1 << 20)
    edge_px = all_valid & ((kmax != key_img) | (kmin != key_img)) & (key_img >= 0)
    patches = []
    for f in found:
        approx = f["approx"]
        flags = edge_px[approx[:, 1], approx[:, 0]].tolist()
        box, m = f["box"], f["mask"]  # the patch's pixels: m inside box
        nrm = None
        if normals is not None:
            v = column_mean(normals[box][m])
            nv = float(np.linalg.norm(v))
            nrm = tuple(float(a) for a in (v / nv if nv > 1e-9 else v))
        poly = f["poly"]
        if poly.geom_type == "Polygon" and len(poly.exterior.coords) - 1 != len(f["pts"]):
            coords = tuple((float(a), float(b)) for a, b in list(poly.exterior.coords)[:-1])
            flags = [False] * len(coords)
        else:
            coords = tuple(map(tuple, f["pts"].tolist()))
        c = poly.centroid
        lab = f["label"]
        patches.append(
            Patch(
                id=f["id"],
                label=lab,
                colour_type=(colour_of or {}).get(lab),
                surface=(surface_of or {}).get(lab),
                normal=nrm,  # type: ignore[arg-type]
                polygon=coords,
                edge_flags=tuple(flags),
                area_m2=float(poly.area),
                pixels=int(m.sum()),
                centroid=(float(c.x), float(c.y)),
                height=float(z[box][m].mean()) if z is not None else 0.0,
                neighbours=tuple(sorted(nb[f["id"]])),
                boundary=np.ascontiguousarray(xy[f["contour"][:, 1], f["contour"][:, 0]], dtype=np.float64),
                boundary_flags=edge_px[f["contour"][:, 1], f["contour"][:, 0]].copy(),
            )
        )
    return PatchSet(patches=tuple(patches), ids=ids)
