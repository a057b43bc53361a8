"""Speed profile along a planned path: speed limit, lateral acceleration, stops at cusps and at the end."""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["SpeedConfig", "speed_profile"]


class SpeedConfig(BaseModel):
    """Dynamic limits: lateral [m/s²] and braking [m/s²] accelerations (the HELM limits driving acceleration)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    max_lateral_accel: float = Field(1.0, gt=0.0, description="[m/s²]")
    max_decel: float = Field(1.0, gt=0.0, description="[m/s²]")


def speed_profile(
    s: np.ndarray,
    curvature: np.ndarray,
    direction: np.ndarray,
    limit: float,
    *,
    stop_at_end: bool = True,
    cfg: SpeedConfig = SpeedConfig(),
) -> np.ndarray:
    """Return signed speeds (N,) [m/s] along arc lengths s (N,) [m] under `limit` [m/s]."""
    s = np.asarray(s, dtype=np.float64)
    n = len(s)
    if n == 0:
        return np.zeros(0)
    k = np.abs(np.asarray(curvature, dtype=np.float64))
    v = np.full(n, max(0.0, float(limit)))
    v = np.minimum(v, np.sqrt(cfg.max_lateral_accel / np.maximum(k, 1e-9)))
    d = np.asarray(direction, dtype=np.float64)
    cusp = np.zeros(n, dtype=bool)
    cusp[1:] = d[1:] != d[:-1]
    v[cusp] = 0.0
    if stop_at_end:
        v[-1] = 0.0
    ds = np.diff(s)
    for i in range(n - 2, -1, -1):  # braking pass: every slow-down is reachable at max_decel
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * cfg.max_decel * ds[i]))
    return v * np.where(d < 0, -1.0, 1.0)
