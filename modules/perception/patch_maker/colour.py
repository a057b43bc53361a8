"""Colour segmentation: Gaussian colour classes in RGB, quadratic discrimination, adaptation from the images.

Seeds: Sidewalk 1986 §3.3.4 and §3.4.3 (the map names colour types such as GRAY and GREEN; Wallace's
quadratic discrimination of multivariate normal RGB classes) and Navlab 1990 §2.2.1 (SCARF: several
classes per colour type — sunlit, shaded, wet — whose statistics are re-estimated from the labelled
pixels of recent frames, so the classifier follows the light and the surfaces it actually sees).

The classes start from what the map says — a colour type and a nominal colour — with generous
priors: a lit class at the nominal colour and a shaded class of unknown darkness, both stretched
along their colour ray. They know nothing of how the world is drawn; `train` fits them to the
pixels whose type is known, `adapt` follows them from frame to frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from modules.perception.column_mean import column_mean
from modules.perception.errors import PerceptionError

__all__ = ["ColourClass", "ColourModel", "ColourModelError", "ColourPrior"]


class ColourModelError(PerceptionError, ValueError):
    """A colour class with a bad mean or covariance, or a colour without a type."""


def _monomials(x: np.ndarray) -> np.ndarray:
    """Return the quadratic monomials (N, 6) x0², x1², x2², x0·x1, x0·x2, x1·x2 of (N, 3) float64 pixels.

    Filled column by column: stacking six columns into a tall, narrow array is far slower.
    """
    q = np.empty((len(x), 6))
    a, b, c = x[:, 0], x[:, 1], x[:, 2]
    for k, (u, v) in enumerate(((a, a), (b, b), (c, c), (a, b), (a, c), (b, c))):
        np.multiply(u, v, out=q[:, k])
    return q


def _best_class(g: np.ndarray, m2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return for each pixel of (K, N) discriminants `g` the best class (N,) (the first on ties, as np.argmax),
    its discriminant (N,) and its squared Mahalanobis distance (N,) from (K, N) `m2`."""
    if np.isnan(g).any():
        best = np.argmax(g, axis=0)
        at = np.arange(g.shape[1])
        return best, g[best, at], m2[best, at]
    best = np.zeros(g.shape[1], dtype=np.intp)
    top, top_m2 = g[0].copy(), m2[0].copy()
    for j in range(1, len(g)):
        up = g[j] > top
        best[up] = j
        np.copyto(top, g[j], where=up)
        np.copyto(top_m2, m2[j], where=up)
    return best, top, top_m2


def _nearest(d2: list[np.ndarray]) -> np.ndarray:
    """Return for each pixel the index of the smallest of the (N,) distances `d2` (the first on ties, as np.argmin)."""
    if any(np.isnan(d).any() for d in d2):
        return np.argmin(np.stack(d2, axis=1), axis=1)
    best = np.zeros(len(d2[0]), dtype=np.intp)
    low = d2[0].copy()
    for j in range(1, len(d2)):
        down = d2[j] < low
        best[down] = j
        np.copyto(low, d2[j], where=down)
    return best


def _row_sum(a: np.ndarray) -> np.ndarray:
    """Return the sum of each row of (N, K) `a`, the columns added left to right (what a.sum(axis=1) does for K < 8)."""
    if a.shape[1] >= 8:
        return a.sum(axis=1)
    out = a[:, 0].copy()
    for j in range(1, a.shape[1]):
        out += a[:, j]
    return out


@dataclass(frozen=True)
class ColourPrior:
    """How little the map's nominal colour is trusted: spreads of the starting classes.

    `chroma_sigma` per channel, relative to the class's mean level (darker surfaces vary less in
    absolute terms), at least `chroma_floor` [DN]; `brightness_sigma` relative spread
    along the colour ray (lighting and weathering change brightness far more than hue); the shaded
    class starts `shade_brightness` as bright as the nominal with relative spread `shade_sigma` —
    a guess of "darker, by how much unknown", left for `train` and `adapt` to settle.
    """

    chroma_sigma: float = 0.15
    chroma_floor: float = 4.0
    brightness_sigma: float = 0.25
    shade_brightness: float = 0.5
    shade_sigma: float = 0.35
    #: A shaded class only learns from pixels at most this bright relative to its lit class, and the lit
    #: class only from pixels at least 1/`shade_ratio` as bright as its shade: a frame without shadows
    #: teaches nothing about shade (else the shaded class drifts up into the lit one and shadows go unlabelled).
    shade_ratio: float = 0.8
    #: Least relative spread along the colour ray each class keeps through adaptation: the light on a
    #: lit surface drifts a little, the darkness of a shadow a lot (penumbra, open sky, wet ground).
    lit_floor: float = 0.08
    shade_floor: float = 0.25


@dataclass(frozen=True)
class ColourClass:
    """One Gaussian colour class: `mean` (3,) and `cov` (3, 3) in sRGB units (0–255), of a colour type."""

    name: str
    colour_type: str
    mean: tuple[float, float, float]
    cov: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]
    prior: float = 1.0
    shade_of: str | None = None  # the name of the lit class this class is the shade of
    ray_floor: float = 0.0  # least relative spread along the colour ray kept through adaptation


@dataclass
class ColourModel:
    """Classify RGB pixels among Gaussian classes; re-estimate the classes from labelled pixels (Wallace, SCARF).

    Labels are 1-based indices into `types` (0 = rejected: farther than `reject_mahal2` from every class).
    """

    classes: list[ColourClass]
    reject_mahal2: float = 30.0
    min_var: float = 4.0
    shade_ratio: float = ColourPrior.shade_ratio
    types: tuple[str, ...] = field(init=False)
    _means: np.ndarray = field(init=False, repr=False)
    _covs: np.ndarray = field(init=False, repr=False)
    _priors: np.ndarray = field(init=False, repr=False)
    _type_of: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.classes:
            raise ColourModelError("ColourModel needs at least one class")
        types: list[str] = []
        for c in self.classes:
            if c.colour_type not in types:
                types.append(c.colour_type)
        self.types = tuple(types)
        self._means = np.array([c.mean for c in self.classes], dtype=np.float64)
        self._covs = np.array([c.cov for c in self.classes], dtype=np.float64)
        self._priors = np.array([c.prior for c in self.classes], dtype=np.float64)
        self._type_of = np.array([types.index(c.colour_type) + 1 for c in self.classes], dtype=np.int16)
        self._ray_floor = np.array([c.ray_floor for c in self.classes], dtype=np.float64)
        names = [c.name for c in self.classes]
        self._pairs: list[tuple[int, int]] = []  # (lit, shade) class indices
        for i, c in enumerate(self.classes):
            if c.shade_of is not None:
                if c.shade_of not in names:
                    raise ColourModelError(f"colour class {c.name!r}: shade of unknown class {c.shade_of!r}")
                self._pairs.append((names.index(c.shade_of), i))
        for i, c in enumerate(self.classes):
            if self._means[i].shape != (3,) or self._covs[i].shape != (3, 3):
                raise ColourModelError(f"colour class {c.name!r}: mean must be (3,), cov (3, 3)")
            if not np.all(np.isfinite(self._covs[i])):
                raise ColourModelError(f"colour class {c.name!r}: covariance is not finite")
        self._regularise()

    # ---------------------------------------------------------------- construction
    @classmethod
    def from_map(cls, colours: Sequence[tuple[str, Sequence[float]]], prior: ColourPrior = ColourPrior()) -> "ColourModel":
        """Build a lit and a shaded class for each (colour type, nominal sRGB) the map states, with generous priors.

        Nominal colours of one type closer than 8 DN share their classes.
        """
        classes: list[ColourClass] = []
        seen: list[tuple[str, np.ndarray]] = []
        for ctype, nominal in colours:
            m = np.asarray(nominal, dtype=np.float64)
            if m.shape != (3,) or not np.all(np.isfinite(m)):
                raise ColourModelError(f"nominal colour {nominal!r} of {ctype!r}: need three finite channels")
            if not ctype:
                raise ColourModelError(f"nominal colour {nominal!r}: no colour type")
            if any(t == ctype and np.linalg.norm(m - q) < 8.0 for t, q in seen):
                continue
            seen.append((ctype, m))
            k = len(seen)
            shade = m * prior.shade_brightness
            lit = f"{ctype}-{k}-lit"
            for name, mu, rel, of, floor in ((lit, m, prior.brightness_sigma, None, prior.lit_floor),
                                             (f"{ctype}-{k}-shade", shade, prior.shade_sigma, lit, prior.shade_floor)):
                chroma = max(prior.chroma_floor, prior.chroma_sigma * float(mu.mean()))
                cov = np.eye(3) * chroma**2 + rel**2 * np.outer(mu, mu)
                classes.append(ColourClass(name, ctype, tuple(mu), tuple(map(tuple, cov)), shade_of=of, ray_floor=floor))  # type: ignore[arg-type]
        return cls(classes, shade_ratio=prior.shade_ratio)

    # ---------------------------------------------------------------- classification
    def _regularise(self) -> None:
        self._covs = 0.5 * (self._covs + np.transpose(self._covs, (0, 2, 1)))
        reg = self._covs + np.eye(3) * self.min_var
        self._prec = np.linalg.inv(reg)
        self._logdet = np.linalg.slogdet(reg)[1]

    def discriminants(self, rgb: np.ndarray, classes: Sequence[int] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Return (g (N, K) quadratic discriminants, m2 (N, K) squared Mahalanobis distances) of (N, 3) pixels.

        `classes` limits the columns to those class indices (default: every class).
        """
        x = rgb.reshape(-1, 3).astype(np.float64, copy=False)
        sel = np.arange(len(self._means)) if classes is None else np.asarray(list(classes), dtype=np.int64)
        return self._scores(x, sel, by_class=False)

    def _scores(self, x: np.ndarray, sel: np.ndarray, by_class: bool) -> tuple[np.ndarray, np.ndarray]:
        """Return (g, m2) of (N, 3) float64 pixels for the classes `sel`: (N, K), or (K, N) `by_class`.

        The same arithmetic either way; by class, each class's constants are one number per
        contiguous row (adding a (K,) row to each of N short rows is far slower).
        """
        # (x - μ)ᵀ P (x - μ) = [quadratic monomials of x] · A + x · B + c, for all classes at once
        P, mu = self._prec[sel], self._means[sel]
        quad = _monomials(x)
        A = np.stack([P[:, 0, 0], P[:, 1, 1], P[:, 2, 2], 2 * P[:, 0, 1], 2 * P[:, 0, 2], 2 * P[:, 1, 2]], axis=0)
        Pmu = np.einsum("kij,kj->ki", P, mu)
        qa, xb = quad @ A, x @ Pmu.T
        c = np.einsum("ki,ki->k", mu, Pmu)
        half_logdet, log_prior = 0.5 * self._logdet[sel], np.log(self._priors[sel])
        if by_class:
            qa, xb = np.ascontiguousarray(qa.T), np.ascontiguousarray(xb.T)
            c, half_logdet, log_prior = c[:, None], half_logdet[:, None], log_prior[:, None]
        m2 = qa - 2.0 * xb + c
        np.maximum(m2, 0.0, out=m2)
        g = -0.5 * m2 - half_logdet + log_prior
        return g, m2

    def classify(self, rgb: np.ndarray, mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Label (H, W, 3) pixels: (type labels (H, W) int16, class index (H, W) int16 or -1, posterior (H, W) float32).

        The posterior is that of the pixel's colour type (its classes together), the label's confidence.
        """
        h, w = rgb.shape[:2]
        flat = rgb.reshape(-1, 3)
        sel = np.flatnonzero(mask.reshape(-1)) if mask is not None else np.arange(flat.shape[0])
        g, m2 = self._scores(flat[sel].astype(np.float64), np.arange(len(self._means)), by_class=True)
        best, gmax, m2_best = _best_class(g, m2)
        e = np.exp(g - gmax)
        onehot = (self._type_of[:, None] == np.arange(1, len(self.types) + 1)[None, :]).astype(np.float64)
        per_type = np.ascontiguousarray(e.T) @ onehot
        p = per_type[np.arange(len(best)), self._type_of[best] - 1] / _row_sum(per_type)
        ok = m2_best <= self.reject_mahal2
        cls_idx = np.full(flat.shape[0], -1, np.int16)
        labels = np.zeros(flat.shape[0], np.int16)
        post = np.zeros(flat.shape[0], np.float32)
        cls_idx[sel] = np.where(ok, best, -1)
        labels[sel] = np.where(ok, self._type_of[best], 0)
        post[sel] = p
        return labels.reshape(h, w), cls_idx.reshape(h, w), post.reshape(h, w)

    # ---------------------------------------------------------------- re-estimation
    def _reestimate(self, i: int, xs: np.ndarray, rate: float) -> None:
        mu = column_mean(xs)
        if len(xs) > 1:  # np.cov(xs, rowvar=False), its very operations
            xc = xs - mu
            cov = np.dot(xc.T, xc)
            cov *= np.true_divide(1, len(xs) - 1)
        else:
            cov = np.cov(xs, rowvar=False)
        self._means[i] = (1 - rate) * self._means[i] + rate * mu
        self._covs[i] = (1 - rate) * self._covs[i] + rate * cov
        m = self._means[i]
        n2 = float(m @ m)
        if self._ray_floor[i] > 0 and n2 > 1e-9:
            u = m / np.sqrt(n2)
            short = self._ray_floor[i] ** 2 * n2 - float(u @ self._covs[i] @ u)
            if short > 0:
                self._covs[i] += short * np.outer(u, u)

    def train(
        self,
        rgb: np.ndarray,
        types: np.ndarray,
        rate: float = 0.8,
        rounds: int = 1,
        trim_mahal2: float = 9.0,
        min_pixels: int = 30,
        max_pixels: int = 1500,
    ) -> int:
        """Re-estimate the classes from pixels whose colour type is known; return how many pixels taught them.

        `types` (H, W) int: 1-based index into `types` of each pixel's known type, 0 = unknown (the
        PERCEPTION MONITOR's predicted objects say which). Each labelled pixel joins the class of its
        type with the nearest mean (nearest-mean clustering, as SCARF collects new statistics) unless
        it lies farther than `trim_mahal2` from that class (leaves on a walk, a wall beside it); each
        class then moves `rate` (0–1) of the way to its pixels' mean and covariance — a shaded class
        only from pixels clearly darker than its lit class, the lit one only from pixels clearly
        brighter than its shade (`shade_ratio`). `rounds` repeats assignment and update.
        """
        x = rgb.reshape(-1, 3)
        lab = np.asarray(types).reshape(-1)
        used = 0
        for t in range(1, len(self.types) + 1):
            idx = np.flatnonzero(lab == t)
            if idx.size < min_pixels:
                continue
            if idx.size > max_pixels:
                idx = idx[:: idx.size // max_pixels]  # an even subsample is plenty for 3x3 statistics
            xs = x[idx].astype(np.float64)
            xt = np.ascontiguousarray(xs.T)  # one row per channel
            members = [i for i in range(len(self.classes)) if self._type_of[i] == t]
            for _ in range(rounds):
                # squared distance to each member's mean, channels added in order
                d2 = [(xt[0] - m[0]) ** 2 + (xt[1] - m[1]) ** 2 + (xt[2] - m[2]) ** 2 for m in self._means[members]]
                best = _nearest(d2)
                _, m2 = self._scores(xs, np.asarray(members, dtype=np.int64), by_class=True)
                near = m2[best, np.arange(len(xs))] <= trim_mahal2
                level = {i: self._means[i].mean() for i in members}
                for j, i in enumerate(members):
                    sel = near & (best == j)
                    if sel.sum() >= min_pixels:
                        xsel = xs[sel]
                        if self._own(i, float(xsel.mean()), level):
                            self._reestimate(i, xsel, rate)
                self._regularise()
            used += int(near.sum())
        return used

    def _own(self, i: int, level: float, levels: dict[int, float]) -> bool:
        """Return whether pixels of mean level `level` [DN] may teach class `i` (not the other side of its lit/shade pair)."""
        for lit, shade in self._pairs:
            if i == shade and lit in levels and level > self.shade_ratio * levels[lit]:
                return False
            if i == lit and shade in levels and level < levels[shade] / self.shade_ratio:
                return False
        return True

    def adapt(
        self,
        rgb: np.ndarray,
        labels: np.ndarray,
        posterior: np.ndarray,
        rate: float = 0.3,
        min_confidence: float = 0.9,
    ) -> int:
        """Re-estimate the classes from this frame's confidently classified pixels, for the next frame (SCARF).

        `labels` and `posterior` are what `classify` returned; pixels of at least `min_confidence`
        teach the classes of their type as in `train`, at `rate` (0–1), in one round, trimmed only as
        far as classification rejects (the light may have moved them). Returns how many did.
        """
        known = np.where(posterior >= min_confidence, labels, 0)
        return self.train(rgb, known, rate=rate, rounds=1, trim_mahal2=self.reject_mahal2)

    def current(self) -> list[ColourClass]:
        """Return the classes as they stand after training and adaptation."""
        return [
            ColourClass(c.name, c.colour_type, tuple(self._means[i]), tuple(map(tuple, self._covs[i])), c.prior, c.shade_of, c.ray_floor)  # type: ignore[arg-type]
            for i, c in enumerate(self.classes)
        ]
