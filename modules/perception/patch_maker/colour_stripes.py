"""Colour classification in row stripes: the quadratic discrimination of every pixel, split among vision workers.

Each pixel is classified on its own (Navlab 1990 §4.4.2.2: "dividing the input … into column stripes.
The input statistical color models were duplicated on each cell"), so the stripes need no overlap;
the classes travel with each request. One worker (or no pool) is `ColourModel.classify` itself.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from modules.parallel import Stripe, StripeOp
from modules.perception.patch_maker.colour import ColourModel

if TYPE_CHECKING:
    from modules.parallel import VisionPool

__all__ = ["CLASSIFICATION", "classify_rows", "classify"]


def classify_rows(arrays: dict[str, np.ndarray], model: ColourModel, stripe: Stripe) -> dict[str, np.ndarray]:
    """Classify one stripe of pixels (a stripe operator): `ColourModel.classify` on its rows."""
    labels, cls_idx, post = model.classify(arrays["rgb"], arrays["mask"])
    return {"labels": labels, "cls_idx": cls_idx, "post": post}


#: Classification by row stripes, no overlap.
CLASSIFICATION = StripeOp(classify_rows, overlap=0, axis=0)


def classify(model: ColourModel, rgb: np.ndarray, mask: np.ndarray, pool: "VisionPool | None" = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return `model.classify(rgb, mask)` — (labels, class index, posterior), each (H, W) — over the pool's workers."""
    if pool is None or pool.workers == 1:
        return model.classify(rgb, mask)
    h, w = mask.shape
    got = pool.run(CLASSIFICATION, {"rgb": rgb, "mask": mask},
                   {"labels": ((h, w), np.int16), "cls_idx": ((h, w), np.int16), "post": ((h, w), np.float32)}, model)
    return got["labels"], got["cls_idx"], got["post"]
