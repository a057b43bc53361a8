"""SCARF's colour-model generator (Navlab 1990 §4.4.2.4, Figure 4.4): ISODATA clustering of the road and off-road pixels.

After each frame the road found picks two training sets, the pixels well inside the road and those
well outside it; every other pixel is "unknown". The Class Image starts from the model in use: each
training pixel takes the most likely class of its own side (the classifier's Bayesian choice). Then
ISODATA runs its two modules a few times — *Sample* (per class the count, sums and sums of squares of
the pixels' colours, hence the means) and *Adjust* (each pixel re-labelled with the class of its side
whose mean colour is nearest; unknown pixels stay unknown) — with ISODATA's housekeeping in between:
a class left with too few pixels is dropped and two classes whose means nearly coincide are merged,
and each freed class is made by splitting the most spread-out class of its side along its widest
channel (mean ± one standard deviation), so every side keeps its k classes. A last Sample gives each
class its mean, covariance and prior N_j / N — the new colour model. At the bootstrap there is no
model yet: each side's pixels start in k brightness bands.
"""

from __future__ import annotations

import numpy as np

from modules.road_following.colour_classes import ColourClass, ColourClasses, classes_of, log_likelihoods

__all__ = ["ISODATA_ITERATIONS", "sample", "adjust", "isodata", "isodata_classes"]

ISODATA_ITERATIONS = 3
#: Housekeeping thresholds (the paper gives none): a class needs this share of its side's pixels (and 4);
#: classes whose means are closer than this [DN] are one.
MIN_SHARE, MERGE_DN = 0.02, 8.0


def sample(x: np.ndarray, labels: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return per class of `labels` (N,) in [0, k) the count (k,), the sums (k, 3) and the sums of squares (k, 3) of `x` (N, 3)."""
    n = np.bincount(labels, minlength=k).astype(np.float64)
    s = np.stack([np.bincount(labels, x[:, c], minlength=k) for c in range(3)], axis=1)
    s2 = np.stack([np.bincount(labels, x[:, c] * x[:, c], minlength=k) for c in range(3)], axis=1)
    return n, s, s2


def adjust(x: np.ndarray, means: np.ndarray) -> np.ndarray:
    """Return each pixel of `x` (N, 3) re-labelled with the nearest of `means` (k, 3) (Euclidean, in RGB)."""
    return np.argmin(((x[:, None, :] - means[None]) ** 2).sum(-1), axis=1)


def _housekeep(n: np.ndarray, s: np.ndarray, s2: np.ndarray, min_members: float) -> np.ndarray:
    """Return the k class means after dropping tiny classes, merging coincident ones and splitting to refill."""
    k = len(n)
    means = s / np.maximum(n, 1.0)[:, None]
    var = np.maximum(s2 / np.maximum(n, 1.0)[:, None] - means**2, 0.0)
    alive = n >= min_members
    for i in range(k):
        for j in range(i + 1, k):
            if alive[i] and alive[j] and np.linalg.norm(means[i] - means[j]) < MERGE_DN:
                w = n[i] + n[j]
                square = (n[i] * (var[i] + means[i] ** 2) + n[j] * (var[j] + means[j] ** 2)) / w
                means[i] = (n[i] * means[i] + n[j] * means[j]) / w
                var[i] = np.maximum(square - means[i] ** 2, 0.0)
                n[i], alive[j] = w, False
    for j in np.flatnonzero(~alive):
        if not alive.any():
            break
        spread = np.where(alive, var.max(axis=1), -1.0)
        i = int(np.argmax(spread))
        c = int(np.argmax(var[i]))
        sd = float(np.sqrt(var[i, c]))
        if sd < 1e-6:
            break
        means[j] = means[i]
        means[j, c] += sd
        means[i, c] -= sd
        var[i, c] = var[j, c] = var[i, c] / 4.0
        var[j] = var[i].copy()
        alive[j] = True
    return means


def isodata(x: np.ndarray, labels: np.ndarray, k: int, iterations: int = ISODATA_ITERATIONS) -> np.ndarray:
    """Return the ISODATA labels (N,) in [0, k) of the pixels `x` (N, 3) from their starting labels (N,) (see the module docstring)."""
    min_members = max(4.0, MIN_SHARE * len(x))
    for _ in range(iterations):
        n, s, s2 = sample(x, labels, k)
        labels = adjust(x, _housekeep(n, s, s2, min_members))
    return labels


def _start(x: np.ndarray, k: int) -> np.ndarray:
    """Return starting labels: k bands of brightness with equal counts (the bootstrap's Class Image)."""
    order = np.argsort(x.sum(axis=1), kind="stable")
    lab = np.empty(len(x), np.int64)
    lab[order] = np.arange(len(x)) * k // max(len(x), 1)
    return lab


def isodata_classes(rgb: np.ndarray, road: np.ndarray, offroad: np.ndarray, previous: ColourClasses | None = None,
                    k: int = 4, iterations: int = ISODATA_ITERATIONS) -> ColourClasses | None:
    """Return the new colour model from the training sets `road` and `offroad` (H, W) bool of `rgb` (H, W, 3).

    The Class Image starts from `previous` (each pixel's most likely class of its side) or, at the
    bootstrap, from brightness bands; None when a side has too few pixels for a class.
    """
    x = rgb.reshape(-1, 3).astype(np.float64)
    total = int(road.sum() + offroad.sum())
    out: list[ColourClass] = []
    for mask, is_road in ((road, True), (offroad, False)):
        xs = x[mask.reshape(-1)]
        if len(xs) < 4 * k:
            return None
        side = [i for i, c in enumerate(previous.classes) if c.road == is_road] if previous is not None else []
        if len(side) == k:
            ll = log_likelihoods(xs.reshape(-1, 1, 3), ColourClasses(classes=tuple(previous.classes[i] for i in side)))  # type: ignore[union-attr]
            labels = np.argmax(ll, axis=0)
        else:
            labels = _start(xs, k)
        got = classes_of(xs, isodata(xs, labels, k, iterations), k, is_road, total)  # the last Sample
        if not got:
            return None
        out += got
    return ColourClasses(classes=tuple(out))
