"""SCARF's per-pixel stages in row stripes (Navlab 1990 §4.4.2): reduction, texture operator, classification.

The Warp divided SCARF's images among its cells by rows (the production machine: "60 rows among ten
cells") with the colour model copied to every cell; here each vision worker reduces its rows of the
camera image, runs the texture operator on them (one classified row of overlap: the Roberts
operators read the row below) and classifies its pixels. The Road Hough and the colour-model
generator stay in the caller: their sums over the whole image would come out in another order
from stripes. One worker (or no pool) runs the same code on the whole image.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from modules.parallel import Stripe, StripeOp
from modules.road_following.colour_classes import Classified, ColourClasses, classify
from modules.road_following.texture import blue_pyramid, texture_image

if TYPE_CHECKING:
    from modules.parallel import VisionPool

__all__ = ["Look", "LookParams", "look_rows", "look_op", "look"]


@dataclass(frozen=True)
class LookParams:
    """What every stripe needs: the classified image's size [px], the texture settings, the colour model (or None)."""

    rows: int
    cols: int
    texture: bool
    alpha: float
    threshold: float
    classes: ColourClasses | None


@dataclass(frozen=True)
class Look:
    """One frame seen: `rgb` (rows, cols, 3) float32, `texture` (rows, cols) float32 or None, the classification or None."""

    rgb: np.ndarray
    texture: np.ndarray | None
    classified: Classified | None


def look_rows(arrays: dict[str, np.ndarray], p: LookParams, stripe: Stripe | None = None) -> dict[str, np.ndarray]:
    """Reduce, texture and classify camera rows `arrays["image"]` (H, W, 3) uint8 into classified rows (a stripe operator).

    The whole image makes `p.rows` rows; a stripe makes the rows of its halo.
    """
    image = arrays["image"]
    rows = p.rows if stripe is None else stripe.halo[1] - stripe.halo[0]
    rgb = cv2.resize(image, (p.cols, rows), interpolation=cv2.INTER_AREA).astype(np.float32)
    out = {"rgb": rgb}
    texture = None
    if p.texture:
        texture = texture_image(blue_pyramid(image, rows, p.cols), p.alpha, p.threshold)
        out["texture"] = texture
    if p.classes is not None:
        cl = classify(rgb, p.classes, texture)
        out.update(label=cl.label.astype(np.int64), probability=cl.probability, p_road=cl.p_road)
    return out


def look_op(row_factor: int) -> StripeOp:
    """Return the stripe operator for a camera image `row_factor` times as tall as the classified image."""
    return StripeOp(look_rows, overlap=1, axis=0, scale={"image": row_factor})


def look(image: np.ndarray, p: LookParams, pool: "VisionPool | None" = None) -> Look:
    """Return the frame seen by `look_rows`, over the pool's workers in row stripes when the image's rows divide evenly."""
    h, rows = image.shape[0], p.rows
    arrays = {"image": image}
    if pool is None or pool.workers == 1 or h % rows:
        got = look_rows(arrays, p)
    else:
        outputs = {"rgb": ((rows, p.cols, 3), np.float32)}
        if p.texture:
            outputs["texture"] = ((rows, p.cols), np.float32)
        if p.classes is not None:
            outputs.update(label=((rows, p.cols), np.int64), probability=((rows, p.cols), np.float32), p_road=((rows, p.cols), np.float32))
        got = pool.run(look_op(h // rows), arrays, outputs, p)
    cl = None
    if p.classes is not None:
        cl = Classified(label=got["label"], probability=got["probability"], p_road=got["p_road"])
    return Look(rgb=got["rgb"], texture=got.get("texture"), classified=cl)
