"""Colour segmentation: Gaussian colour classes in RGB, quadratic discrimination, frame-to-frame adaptation.

Seeds: Sidewalk 1986 §3.4.3 (Wallace's quadratic discrimination of multivariate normal RGB classes) and
Navlab 1990 §2.2.1 (SCARF: several classes per colour — sunlit and shaded — re-estimated every frame from
the confidently classified pixels, so slow illumination change does not derail the classifier).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

#: Relative colour of skylight to sunlight: what lights a shadow is bluer than what lights the sun side.
SKYLIGHT_TINT: tuple[float, float, float] = (0.90, 0.96, 1.12)

__all__ = [
    "SKYLIGHT_TINT",
    "ColourClass",
    "ColourModel",
    "ColourModelError",
    "colour_type_name",
]


class ColourModelError(ValueError):
    """A colour class with a bad mean or covariance."""


def colour_type_name(mean_rgb: Sequence[float]) -> str:
    """Name the colour type (GREY, GREEN, BROWN, RED, BLUE, YELLOW, DARK, WHITE) of an sRGB mean (0–255)."""
    r, g, b = (float(v) for v in mean_rgb)
    mx, mn = max(r, g, b), min(r, g, b)
    sat = (mx - mn) / mx if mx > 1e-6 else 0.0
    if mx < 45:
        return "DARK"
    if sat < 0.18:
        return "WHITE" if mn > 215 else "GREY"
    if g >= r and g >= b:
        return "GREEN"
    if b >= r and b >= g:
        return "BLUE"
    # red dominant
    if g > 0.75 * r:
        return "YELLOW"
    if g > 0.45 * r:
        return "BROWN"
    return "RED"


@dataclass(frozen=True)
class ColourClass:
    """One Gaussian colour class: `mean` (3,) and `cov` (3, 3) in sRGB units (0–255), of a colour type."""

    name: str
    colour_type: str
    mean: tuple[float, float, float]
    cov: tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]
    prior: float = 1.0


@dataclass
class ColourModel:
    """Classify RGB pixels among Gaussian classes and re-estimate the classes frame to frame (SCARF).

    Labels are 1-based indices into `types` (0 = rejected: farther than `reject_mahal2` from every class).
    """

    classes: list[ColourClass]
    reject_mahal2: float = 30.0
    min_var: float = 4.0
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
        for i, c in enumerate(self.classes):
            if self._means[i].shape != (3,) or self._covs[i].shape != (3, 3):
                raise ColourModelError(f"colour class {c.name!r}: mean must be (3,), cov (3, 3)")
            if not np.all(np.isfinite(self._covs[i])):
                raise ColourModelError(f"colour class {c.name!r}: covariance is not finite")
        self._regularise()

    # ---------------------------------------------------------------- construction
    @classmethod
    def from_predicted(
        cls,
        colours: Sequence[tuple[Sequence[float], Sequence[float]]],
        shade_factor: float = 0.5,
        std_inflation: float = 1.2,
        brightness_sigma: float = 0.12,
        shade_tint: Sequence[float] = SKYLIGHT_TINT,
    ) -> "ColourModel":
        """Build sunlit and shaded classes for each predicted (mean, std) sRGB colour; types named by hue.

        Shade is skylight only: `shade_factor` as bright and tinted by `shade_tint` (bluer). Each class's
        covariance adds brightness variation along its own mean colour (`brightness_sigma`, relative),
        so a class stretches along its colour ray rather than swelling in every direction.
        """
        classes: list[ColourClass] = []
        seen: list[np.ndarray] = []
        tint = np.asarray(shade_tint, dtype=np.float64)
        for mean, std in colours:
            m = np.asarray(mean, dtype=np.float64)
            s = np.maximum(np.asarray(std, dtype=np.float64) * std_inflation, 3.0)
            if m.shape != (3,) or s.shape != (3,):
                raise ColourModelError(f"predicted colour {mean!r}/{std!r}: need three channels each")
            if any(np.linalg.norm(m - q) < 8.0 for q in seen):
                continue
            seen.append(m)
            ctype = colour_type_name(m)
            k = len(seen)
            for tag, mu, sd in (("sun", m, s), ("shade", m * shade_factor * tint, s * max(shade_factor, 0.3))):
                cov = np.diag(sd**2) + brightness_sigma**2 * np.outer(mu, mu)
                classes.append(ColourClass(f"{ctype}-{k}-{tag}", ctype, tuple(mu), tuple(map(tuple, cov))))  # type: ignore[arg-type]
        return cls(classes)

    # ---------------------------------------------------------------- classification
    def _regularise(self) -> None:
        self._covs = 0.5 * (self._covs + np.transpose(self._covs, (0, 2, 1)))
        reg = self._covs + np.eye(3) * self.min_var
        self._prec = np.linalg.inv(reg)
        self._logdet = np.linalg.slogdet(reg)[1]

    def discriminants(self, rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return (g (N, K) quadratic discriminants, m2 (N, K) squared Mahalanobis distances) of (N, 3) pixels."""
        x = rgb.reshape(-1, 3).astype(np.float64)
        k = len(self._means)
        m2 = np.empty((x.shape[0], k))
        for i in range(k):
            d = x - self._means[i]
            m2[:, i] = ((d @ self._prec[i]) * d).sum(axis=1)
        g = -0.5 * m2 - 0.5 * self._logdet[None, :] + np.log(self._priors)[None, :]
        return g, m2

    def classify(self, rgb: np.ndarray, mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Label (H, W, 3) pixels: (type labels (H, W) int16, class index (H, W) int16 or -1, posterior (H, W) float32)."""
        h, w = rgb.shape[:2]
        flat = rgb.reshape(-1, 3)
        sel = np.flatnonzero(mask.reshape(-1)) if mask is not None else np.arange(flat.shape[0])
        g, m2 = self.discriminants(flat[sel])
        best = np.argmax(g, axis=1)
        gmax = g[np.arange(g.shape[0]), best]
        p = 1.0 / np.exp(g - gmax[:, None]).sum(axis=1)
        ok = m2[np.arange(m2.shape[0]), best] <= self.reject_mahal2
        cls_idx = np.full(flat.shape[0], -1, np.int16)
        labels = np.zeros(flat.shape[0], np.int16)
        post = np.zeros(flat.shape[0], np.float32)
        cls_idx[sel] = np.where(ok, best, -1)
        labels[sel] = np.where(ok, self._type_of[best], 0)
        post[sel] = p
        return labels.reshape(h, w), cls_idx.reshape(h, w), post.reshape(h, w)

    # ---------------------------------------------------------------- adaptation
    def adapt(
        self,
        rgb: np.ndarray,
        class_idx: np.ndarray,
        posterior: np.ndarray,
        rate: float = 0.3,
        min_confidence: float = 0.9,
        min_pixels: int = 40,
        max_pixels: int = 1500,
    ) -> None:
        """Re-estimate each class from its confidently classified pixels, blended at `rate` (0–1)."""
        x = rgb.reshape(-1, 3)
        ci = class_idx.reshape(-1)
        conf = posterior.reshape(-1) >= min_confidence
        for i in range(len(self._means)):
            sel = conf & (ci == i)
            n = int(sel.sum())
            if n < min_pixels:
                continue
            idx = np.flatnonzero(sel)
            if n > max_pixels:
                idx = idx[:: n // max_pixels]  # an even subsample is plenty for 3x3 statistics
            xs = x[idx].astype(np.float64)
            mu = xs.mean(axis=0)
            cov = np.cov(xs, rowvar=False)
            self._means[i] = (1 - rate) * self._means[i] + rate * mu
            self._covs[i] = (1 - rate) * self._covs[i] + rate * cov
        self._regularise()

    def current(self) -> list[ColourClass]:
        """Return the classes as they stand after adaptation."""
        return [
            ColourClass(c.name, c.colour_type, tuple(self._means[i]), tuple(map(tuple, self._covs[i])), c.prior)  # type: ignore[arg-type]
            for i, c in enumerate(self.classes)
        ]
