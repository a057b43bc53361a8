"""PATCH MAKER: colour, range and overlap (colored-range) segmentation into patches (seed: Sidewalk 1986 §3.2.1, §3.4).

One common data interface for the layers above: each segmentation module returns a label image and a
`PatchSet` (colour type, surface type and normal, boundary polygon, neighbours of every patch).
Files: `colour` (Gaussian colour classes, quadratic discrimination, adaptation), `range_seg` (jump
edges, normals, curvature, surface labels), `overlap` (AND of colour and surface labels), `patches`
(label image → patches), `segmentation` (the three modules behind one call).
"""

from modules.perception.patch_maker.colour import ColourClass, ColourModel, ColourModelError, ColourPrior
from modules.perception.patch_maker.overlap import overlap_labels, split_label
from modules.perception.patch_maker.patches import Patch, PatchSet, make_patches
from modules.perception.patch_maker.range_seg import RangeSegParams, SurfaceType, segment_range, unwrap_range
from modules.perception.patch_maker.segmentation import (
    Segmentation, SegmentationParams, Segmented, classify_colours, colour_mask, make_segmentation, patches_of,
)

__all__ = [
    "ColourClass", "ColourModel", "ColourModelError", "ColourPrior",
    "overlap_labels", "split_label",
    "Patch", "PatchSet", "make_patches",
    "RangeSegParams", "SurfaceType", "segment_range", "unwrap_range",
    "Segmentation", "SegmentationParams", "Segmented", "make_segmentation", "colour_mask", "classify_colours", "patches_of",
]
