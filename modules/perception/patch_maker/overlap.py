"""Overlap segmentation: the colour-surface label of each pixel is the AND of its colour and surface labels.

Seed: Sidewalk 1986 §3.4.4, Figure 11.
"""

from __future__ import annotations

import numpy as np

from modules.perception.patch_maker.range_seg import SurfaceType

__all__ = ["N_SURFACE", "overlap_labels", "split_label"]

N_SURFACE = len(SurfaceType)


def overlap_labels(colour_labels: np.ndarray, surface_labels: np.ndarray) -> np.ndarray:
    """AND two (H, W) label images into one (H, W) int32 colour-surface label (0 where either is 0)."""
    if colour_labels.shape != surface_labels.shape:
        raise ValueError(f"overlap_labels: colour {colour_labels.shape} and surface {surface_labels.shape} differ")
    c = colour_labels.astype(np.int32)
    s = surface_labels.astype(np.int32)
    return np.where((c > 0) & (s > 0), c * N_SURFACE + s, 0).astype(np.int32)


def split_label(label: int) -> tuple[int, int]:
    """Return (colour label, SurfaceType value) of a colour-surface label."""
    return label // N_SURFACE, label % N_SURFACE
