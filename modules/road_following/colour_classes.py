"""SCARF's colour classes (Navlab 1990 §2.2.1, §4.4.2): Gaussians in full RGB, four for road, four off-road.

Every pixel is compared with all classes; the output is the most probable class, its probability,
and the probability that the pixel is road (the sum over the road classes). After each frame the
classes are re-estimated from the road the frame found: road and off-road pixels are each split by
nearest-mean clustering (the Sample/Adjust loop seeded by the last frame's means; `isodata` is the
paper's full colour-model generator) and each cluster gives a mean, a covariance and a prior.

With the texture operator (§4.4.2.2) a pixel's measurement is [R, G, B, texture]: a class may carry
texture statistics (mean, variance [count²]), taken as independent of its colour, and adds their
Gaussian term to the likelihood; without them (or without a texture image) the classes are RGB alone.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict

__all__ = ["ColourClass", "ColourClasses", "Classified", "classify", "log_likelihoods", "estimate_classes", "classes_of", "attach_texture", "MIN_VAR"]

_FROZEN = ConfigDict(frozen=True, extra="forbid")
MIN_VAR = 4.0  # [DN²] floor on each class's variance, so a flat patch does not make a needle
_Vec3 = tuple[float, float, float]


class ColourClass(BaseModel):
    """One colour class: RGB mean [0–255], covariance [DN²], prior weight, road or off-road; texture mean and variance [count, count²]."""

    model_config = _FROZEN

    mean: _Vec3
    cov: tuple[_Vec3, _Vec3, _Vec3]
    weight: float
    road: bool
    texture_mean: float | None = None
    texture_var: float | None = None


class ColourClasses(BaseModel):
    """The classes in use (road ones and off-road ones)."""

    model_config = _FROZEN

    classes: tuple[ColourClass, ...]


class Classified(BaseModel):
    """A classified image: per pixel the best class, its probability and P(road); arrays (H, W)."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    label: np.ndarray  # int, index into the classes
    probability: np.ndarray  # float32, posterior of the best class
    p_road: np.ndarray  # float32, summed posterior of the road classes


def log_likelihoods(rgb: np.ndarray, classes: ColourClasses, texture: np.ndarray | None = None) -> np.ndarray:
    """Return each class's log likelihood × prior of every pixel of `rgb` (H, W, 3), (K, H·W) float64 (constants dropped).

    `texture` (H, W) adds each class's texture term where the class has texture statistics.
    """
    x = rgb.reshape(-1, 3).astype(np.float64)
    t = None if texture is None else texture.reshape(-1).astype(np.float64)
    logp = np.empty((len(classes.classes), x.shape[0]))
    for i, c in enumerate(classes.classes):
        cov = np.asarray(c.cov) + np.eye(3) * 1e-6
        inv = np.linalg.inv(cov)
        d = x - np.asarray(c.mean)
        maha = np.einsum("ni,ij,nj->n", d, inv, d)
        logp[i] = -0.5 * maha - 0.5 * np.linalg.slogdet(cov)[1] + np.log(max(c.weight, 1e-6))
        if t is not None and c.texture_mean is not None and c.texture_var is not None:
            logp[i] += -0.5 * (t - c.texture_mean) ** 2 / c.texture_var - 0.5 * np.log(c.texture_var)
    return logp


def classify(rgb: np.ndarray, classes: ColourClasses, texture: np.ndarray | None = None) -> Classified:
    """Classify every pixel of `rgb` (H, W, 3) [0–255] against all classes (Gaussian likelihood × prior); `texture` (H, W) optional."""
    h, w = rgb.shape[:2]
    logp = log_likelihoods(rgb, classes, texture)
    logp -= logp.max(axis=0, keepdims=True)
    post = np.exp(logp)
    post /= post.sum(axis=0, keepdims=True)
    road = np.array([c.road for c in classes.classes])
    label = post.argmax(axis=0)
    return Classified(label=label.reshape(h, w), probability=post.max(axis=0).reshape(h, w).astype(np.float32),
                      p_road=post[road].sum(axis=0).reshape(h, w).astype(np.float32))


def _clusters(x: np.ndarray, k: int, seeds: np.ndarray | None, iters: int, road: bool) -> list[ColourClass]:
    """Split the pixels `x` (N, 3) into up to k classes by nearest-mean clustering from `seeds` (k, 3)."""
    if len(x) < 3:
        return []
    if seeds is None or len(seeds) != k:
        order = np.argsort(x.sum(axis=1))
        seeds = np.stack([x[order[int((i + 0.5) * len(x) / k)]] for i in range(k)])
    means = seeds.astype(np.float64).copy()
    for _ in range(iters):
        lab = np.argmin(((x[:, None, :] - means[None]) ** 2).sum(-1), axis=1)
        for j in range(k):
            m = lab == j
            if m.any():
                means[j] = x[m].mean(axis=0)
    lab = np.argmin(((x[:, None, :] - means[None]) ** 2).sum(-1), axis=1)
    return classes_of(x, lab, k, road, len(x))


def classes_of(x: np.ndarray, labels: np.ndarray, k: int, road: bool, total: int) -> list[ColourClass]:
    """Return a class per label in [0, k) of the pixels `x` (N, 3) with at least 4 of them: mean, covariance (floored by MIN_VAR), prior n / `total`."""
    out = []
    for j in range(k):
        pts = x[labels == j]
        if len(pts) < 4:
            continue
        cov = np.cov(pts.T) + np.eye(3) * MIN_VAR
        out.append(ColourClass(mean=tuple(pts.mean(axis=0)), cov=tuple(map(tuple, cov)), weight=len(pts) / total, road=road))
    return out


def estimate_classes(rgb: np.ndarray, road: np.ndarray, offroad: np.ndarray, previous: ColourClasses | None = None,
                     k: int = 4, iters: int = 3) -> ColourClasses | None:
    """Return k road and k off-road classes from the pixels of `rgb` (H, W, 3) under the masks (H, W) bool.

    Clustering starts from the previous classes' means, so classes keep their identity frame to
    frame; None when either set has too few pixels to estimate from.
    """
    x = rgb.reshape(-1, 3).astype(np.float64)
    out: list[ColourClass] = []
    for mask, is_road in ((road, True), (offroad, False)):
        seeds = None
        if previous is not None:
            prev = [c.mean for c in previous.classes if c.road == is_road]
            seeds = np.asarray(prev) if len(prev) == k else None
        got = _clusters(x[mask.reshape(-1)], k, seeds, iters, is_road)
        if not got:
            return None
        share = mask.sum() / max(mask.sum() + (offroad if is_road else road).sum(), 1)
        out += [c.model_copy(update={"weight": c.weight * share}) for c in got]
    return ColourClasses(classes=tuple(out))


def attach_texture(classes: ColourClasses, texture: np.ndarray, road: np.ndarray, offroad: np.ndarray,
                   previous: ColourClasses | None = None, min_var: float = 1.0) -> ColourClasses:
    """Return `classes` with texture statistics: the previous classes' (the texture model is not adapted, §4.4.2.4), else measured.

    Measured once, at the bootstrap: the mean and variance [count²] (at least `min_var`) of the
    texture image (H, W) over the road pixels go to every road class, over the off-road pixels to
    every off-road class.
    """
    stats: dict[bool, tuple[float, float]] = {}
    if previous is not None:
        for c in previous.classes:
            if c.texture_mean is not None and c.texture_var is not None:
                stats.setdefault(c.road, (c.texture_mean, c.texture_var))
    for is_road, mask in ((True, road), (False, offroad)):
        if is_road not in stats:
            t = texture[mask].astype(np.float64)
            stats[is_road] = (float(t.mean()), max(float(t.var()), min_var)) if t.size else (0.0, max(float(texture.var()), min_var))
    return ColourClasses(classes=tuple(c.model_copy(update={"texture_mean": stats[c.road][0], "texture_var": stats[c.road][1]})
                                       for c in classes.classes))
