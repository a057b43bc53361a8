"""ALVINN's network (Navlab 1990 §2.2.3): a small fully connected net from a 30×32 image to a steering bar.

Three layers, written by hand in numpy (no framework to install): the input retina (30×32 = 960
units), a few hidden units (tanh), and ~30 output units (logistic) laid along the steering
curvatures from hard left to hard right. The training target is a Gaussian hump centred on the
right curvature; the output is read as the centre of mass of the hump around the strongest unit.
Trained by back-propagation (mean squared error, Adam, mini-batches). Weights are saved to and
loaded from an `.npz` file (never a pickle), with the geometry the net was trained for.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from modules.road_following.errors import AlvinnModelError

__all__ = ["AlvinnShape", "AlvinnNet", "steering_targets", "decode_steering"]

_ARRAYS = ("w1", "b1", "w2", "b2")


class AlvinnShape(BaseModel):
    """The net's shape and what its ends mean: retina [px], hidden units, output units over curvatures [1/m], look-ahead [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    rows: int = Field(30, ge=4)
    cols: int = Field(32, ge=4)
    hidden: int = Field(5, ge=1)
    outputs: int = Field(31, ge=3)
    max_curvature_per_m: float = Field(0.08, gt=0.0)
    lookahead_m: float = Field(12.0, gt=0.0)
    target_sigma_units: float = Field(1.5, gt=0.0)

    @property
    def curvatures(self) -> np.ndarray:
        """Return the curvature [1/m] of each output unit, (outputs,), left (+) first."""
        return np.linspace(self.max_curvature_per_m, -self.max_curvature_per_m, self.outputs)


def steering_targets(curvature: np.ndarray, shape: AlvinnShape) -> np.ndarray:
    """Return the Gaussian-hump targets (N, outputs) for curvatures (N,) [1/m] (clipped to the bar)."""
    grid = shape.curvatures
    step = grid[0] - grid[1]
    pos = (shape.max_curvature_per_m - np.clip(np.asarray(curvature, float), -shape.max_curvature_per_m,
                                                  shape.max_curvature_per_m)) / step
    units = np.arange(shape.outputs)[None, :]
    return np.exp(-0.5 * ((units - pos[:, None]) / shape.target_sigma_units) ** 2)


def decode_steering(out: np.ndarray, shape: AlvinnShape) -> tuple[np.ndarray, np.ndarray]:
    """Return the curvature [1/m] and a confidence [0–1] of each output row (N, outputs).

    The curvature is the centre of mass of the units within ±2σ of the strongest one; the confidence is
    how well the output matches a clean hump there (1 − mean squared difference).
    """
    out = np.atleast_2d(out)
    grid = shape.curvatures
    j = out.argmax(axis=1)
    units = np.arange(shape.outputs)[None, :]
    near = np.abs(units - j[:, None]) <= 2.0 * shape.target_sigma_units
    w = np.where(near, np.clip(out, 0.0, None), 0.0)
    pos = (w * units).sum(axis=1) / np.maximum(w.sum(axis=1), 1e-9)
    curv = np.interp(pos, np.arange(shape.outputs), grid)
    hump = np.exp(-0.5 * ((units - pos[:, None]) / shape.target_sigma_units) ** 2)
    conf = np.clip(1.0 - ((out - hump) ** 2).mean(axis=1) * 4.0, 0.0, 1.0)
    return curv, conf


class AlvinnNet:
    """The network's weights and the maths: forward pass, back-propagation training, npz save/load."""

    def __init__(self, shape: AlvinnShape, rng: np.random.Generator) -> None:
        """Start with small random weights drawn from `rng`."""
        self.shape = shape
        n_in = shape.rows * shape.cols
        self.w1 = rng.normal(0.0, 1.0 / np.sqrt(n_in), (n_in, shape.hidden))
        self.b1 = np.zeros(shape.hidden)
        self.w2 = rng.normal(0.0, 1.0 / np.sqrt(shape.hidden), (shape.hidden, shape.outputs))
        self.b2 = np.zeros(shape.outputs)

    def forward(self, x: np.ndarray) -> np.ndarray:
        """Return the output units (N, outputs) for retinas x (N, rows·cols)."""
        h = np.tanh(x @ self.w1 + self.b1)
        return 1.0 / (1.0 + np.exp(-(h @ self.w2 + self.b2)))

    def train(self, x: np.ndarray, targets: np.ndarray, rng: np.random.Generator, *, epochs: int = 60, batch: int = 64,
              lr: float = 0.003, weight_decay: float = 1e-4) -> list[float]:
        """Back-propagate on (x (N, rows·cols), targets (N, outputs)); return the mean squared error per epoch."""
        params = [self.w1, self.b1, self.w2, self.b2]
        m = [np.zeros_like(p) for p in params]
        v = [np.zeros_like(p) for p in params]
        b1_, b2_, eps = 0.9, 0.999, 1e-8
        step = 0
        losses = []
        n = len(x)
        for _ in range(epochs):
            order = rng.permutation(n)
            total = 0.0
            for k in range(0, n, batch):
                idx = order[k:k + batch]
                xb, tb = x[idx], targets[idx]
                a1 = xb @ self.w1 + self.b1
                h = np.tanh(a1)
                y = 1.0 / (1.0 + np.exp(-(h @ self.w2 + self.b2)))
                err = y - tb
                total += float((err ** 2).sum())
                d2 = err * y * (1.0 - y) * (2.0 / len(idx))
                g_w2 = h.T @ d2 + weight_decay * self.w2
                g_b2 = d2.sum(axis=0)
                d1 = (d2 @ self.w2.T) * (1.0 - h * h)
                g_w1 = xb.T @ d1 + weight_decay * self.w1
                g_b1 = d1.sum(axis=0)
                step += 1
                for p, g, mi, vi in zip(params, (g_w1, g_b1, g_w2, g_b2), m, v):
                    mi *= b1_
                    mi += (1 - b1_) * g
                    vi *= b2_
                    vi += (1 - b2_) * g * g
                    p -= lr * (mi / (1 - b1_ ** step)) / (np.sqrt(vi / (1 - b2_ ** step)) + eps)
            losses.append(total / (n * self.shape.outputs))
        return losses

    def save(self, path: str | Path) -> Path:
        """Write the weights and the shape to an `.npz` file."""
        path = Path(path)
        np.savez(path, w1=self.w1, b1=self.b1, w2=self.w2, b2=self.b2, shape=np.array(self.shape.model_dump_json()))
        return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")

    @classmethod
    def load(cls, path: str | Path) -> "AlvinnNet":
        """Read a net written by `save`; AlvinnModelError names the file and what is wrong."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as f:
                missing = [k for k in (*_ARRAYS, "shape") if k not in f.files]
                if missing:
                    raise AlvinnModelError(f"{path}: not an ALVINN weights file (missing {', '.join(missing)})")
                shape = AlvinnShape.model_validate_json(str(f["shape"]))
                arrays = {k: np.asarray(f[k], np.float64) for k in _ARRAYS}
        except FileNotFoundError:
            raise AlvinnModelError(f"{path}: no such file") from None
        except (OSError, ValueError) as exc:
            if isinstance(exc, AlvinnModelError):
                raise
            raise AlvinnModelError(f"{path}: unreadable weights file ({str(exc).splitlines()[0]})") from None
        n_in = shape.rows * shape.cols
        want = {"w1": (n_in, shape.hidden), "b1": (shape.hidden,), "w2": (shape.hidden, shape.outputs), "b2": (shape.outputs,)}
        for k, s in want.items():
            if arrays[k].shape != s:
                raise AlvinnModelError(f"{path}: array {k} has shape {arrays[k].shape}, expected {s}")
        net = cls.__new__(cls)
        net.shape = shape
        for k, a in arrays.items():
            setattr(net, k, a)
        return net
