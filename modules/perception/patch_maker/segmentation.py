"""PATCH MAKER: colour, range and colored-range segmentation modules behind one interface.

Seed: Sidewalk 1986 §3.2.1 and §3.4; each returns a `PatchSet` plus its label image.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from modules.perception.patch_maker.colour import ColourModel
from modules.perception.patch_maker.colour_stripes import classify
from modules.perception.image import ColoredRangeImage
from modules.perception.patch_maker.overlap import overlap_labels, split_label
from modules.perception.patch_maker.patches import PatchSet, make_patches
from modules.perception.patch_maker.range_seg import RangeSegParams, SurfaceFeatures, SurfaceType, segment_range

if TYPE_CHECKING:
    from modules.parallel import VisionPool

__all__ = ["Segmentation", "SegmentationParams", "Segmented", "make_segmentation", "colour_mask", "classify_colours", "patches_of"]


class Segmentation(str, Enum):
    """Which segmentation module makes the patches."""

    COLOUR = "colour"
    RANGE = "range"
    COLORED_RANGE = "colored_range"


@dataclass(frozen=True)
class SegmentationParams:
    """Parameters the PERCEPTION MONITOR derives from the predicted objects (§3.3.4)."""

    min_area_m2: float = 0.3
    range: RangeSegParams = RangeSegParams()
    adapt_rate: float = 0.3
    train_rate: float = 0.8


@dataclass(frozen=True)
class Segmented:
    """One frame's segmentation: the label image (H, W) int32 and its patches."""

    method: Segmentation
    labels: np.ndarray
    patches: PatchSet


def colour_mask(method: Segmentation, img: ColoredRangeImage) -> np.ndarray:
    """Return the (H, W) bool pixels a colour module classifies: valid ones, with a ground point for colour alone."""
    return img.valid if method is Segmentation.COLORED_RANGE else np.all(np.isfinite(img.ground_xy), axis=-1) & img.valid


def classify_colours(
    method: Segmentation,
    rgb: np.ndarray,
    mask: np.ndarray,
    params: SegmentationParams,
    model: ColourModel,
    adapt: bool = True,
    training: np.ndarray | None = None,
    pool: "VisionPool | None" = None,
) -> np.ndarray:
    """Return the colour labels (H, W) int16 of the `mask` pixels of `rgb` (H, W, 3); adapts `model` in place.

    The part of a colour segmentation that carries state from frame to frame: the classes are first
    fitted to the `training` pixels (Wallace), then classify, then follow the confidently
    classified pixels to the next frame (SCARF); see `make_segmentation`.
    """
    if adapt and training is not None and params.train_rate > 0:
        if training.shape != mask.shape:
            raise ValueError(f"{method.value} segmentation: training labels {training.shape}, image {mask.shape}")
        model.train(rgb, np.where(mask, training, 0), rate=params.train_rate)
    colour_lab, cls_idx, post = classify(model, rgb, mask, pool)
    if adapt and params.adapt_rate > 0:
        # what the predicted objects contradict teaches nothing (a shadow taken for another colour type)
        agreed = colour_lab if training is None else np.where((training == 0) | (training == colour_lab), colour_lab, 0)
        model.adapt(rgb, agreed, post, rate=params.adapt_rate)
    return colour_lab


def patches_of(
    method: Segmentation,
    img: ColoredRangeImage,
    params: SegmentationParams,
    colour_lab: np.ndarray | None,
    types: tuple[str, ...] = (),
    surface: tuple[np.ndarray, SurfaceFeatures] | None = None,
) -> Segmented:
    """Make the patches of one frame from its colour labels (`classify_colours`; None for range alone).

    `types` are the colour model's types (what a colour label indexes, 1-based); `surface` the
    frame's `segment_range` result when already computed (else it is computed here).
    """
    if method is Segmentation.COLOUR:
        assert colour_lab is not None
        colour_of = {i + 1: t for i, t in enumerate(types)}
        ps = make_patches(colour_lab, img.ground_xy, img.valid, colour_of=colour_of, min_area_m2=params.min_area_m2)
        return Segmented(method, colour_lab.astype(np.int32), ps)
    surf, feats = surface if surface is not None else segment_range(img.xyz, img.range_m, img.valid, params.range)
    xy = img.xyz[..., :2]
    if method is Segmentation.RANGE:
        surface_of = {int(s): int(s) for s in SurfaceType if s > 0}
        ps = make_patches(surf.astype(np.int32), xy, img.valid, surface_of=surface_of, normals=feats.normal, z=img.xyz[..., 2], min_area_m2=params.min_area_m2)
        return Segmented(method, surf.astype(np.int32), ps)
    assert colour_lab is not None
    lab = overlap_labels(colour_lab, surf)
    colour_of = {}
    surface_of = {}
    for v in np.unique(lab):
        if v <= 0:
            continue
        c, s = split_label(int(v))
        colour_of[int(v)] = types[c - 1]
        surface_of[int(v)] = s
    ps = make_patches(lab, xy, img.valid, colour_of=colour_of, surface_of=surface_of, normals=feats.normal, z=img.xyz[..., 2], min_area_m2=params.min_area_m2)
    return Segmented(method, lab, ps)


def make_segmentation(
    method: Segmentation,
    img: ColoredRangeImage,
    params: SegmentationParams,
    model: ColourModel | None = None,
    adapt: bool = True,
    training: np.ndarray | None = None,
    pool: "VisionPool | None" = None,
) -> Segmented:
    """Segment one colored-range frame with the chosen module; colour modules adapt `model` in place.

    `training` (H, W) int: the colour type each pixel is known to have (1-based into `model.types`,
    0 = unknown); the colour classes are first fitted to those pixels of this frame (Wallace), then
    classify, then follow the confidently classified pixels to the next frame (SCARF). A `pool` of
    several vision workers classifies the pixels in row stripes (the same labels).
    """
    colour_lab = None
    if method in (Segmentation.COLOUR, Segmentation.COLORED_RANGE):
        if model is None:
            raise ValueError(f"{method.value} segmentation needs a ColourModel")
        colour_lab = classify_colours(method, img.rgb, colour_mask(method, img), params, model, adapt, training, pool)
    return patches_of(method, img, params, colour_lab, model.types if model is not None else ())
