"""Input partitioning (Navlab 1990 §4.3.2.2): an image cut into stripes that overlap by the operator's width.

"An m × n image was divided into c vertical stripes to be processed on c different cells. For the
interest operator, the stripes had to overlap by four pixels, due to the width of the operator
window." A `Stripe` is one cell's share along the partitioned axis: its `core` (the rows or columns
whose results it owns) and its `halo` (the core widened by the overlap on each side, clipped to
the image: what it reads). An operator whose output at a pixel depends only on inputs within
`overlap` of it gives on each core exactly what it gives on the whole image.

Stripe boundaries fall on multiples of `align` (in units of the partitioned axis), so that an
operator working on blocks (a 4×4 reduction) never splits one, and so that every stripe holds a
multiple of the pixel quantum (`aligned_for`): BLAS matrix kernels treat a trailing odd pixel
differently from the rest, so a pixel's arithmetic would otherwise depend on where its stripe ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from modules.parallel.errors import StripePlanError

__all__ = ["Stripe", "partition", "aligned_for", "PIXEL_QUANTUM"]

#: Pixels a stripe holds a multiple of (see the module docstring): the widest row block of the BLAS kernels.
PIXEL_QUANTUM = 64


@dataclass(frozen=True)
class Stripe:
    """One stripe along the partitioned axis [px]: `index`, the `core` it owns and the `halo` it reads, half-open."""

    index: int
    core: tuple[int, int]
    halo: tuple[int, int]

    @property
    def inner(self) -> tuple[int, int]:
        """Return the core's position inside the halo (start, stop) [px]."""
        return self.core[0] - self.halo[0], self.core[1] - self.halo[0]


def aligned_for(align: int, pixels_per_unit: int, quantum: int = PIXEL_QUANTUM) -> int:
    """Return the least multiple of `align` whose stripes of `pixels_per_unit` pixels per unit hold a multiple of `quantum` pixels."""
    if align < 1 or pixels_per_unit < 1:
        raise StripePlanError(f"stripe alignment: align {align} and pixels per unit {pixels_per_unit} must be ≥ 1")
    need = quantum // math.gcd(quantum, pixels_per_unit)
    return align * need // math.gcd(align, need)


def partition(length: int, parts: int, overlap: int = 0, align: int = 1) -> tuple[Stripe, ...]:
    """Cut `length` [px] into at most `parts` stripes of near-equal cores on multiples of `align`, halos `overlap` wider.

    The halo's widening is rounded up to a multiple of `align` too. Fewer stripes come back when the
    length holds fewer aligned blocks than `parts`; never an empty one.
    """
    if length < 1 or parts < 1 or overlap < 0 or align < 1:
        raise StripePlanError(f"stripes: length {length}, parts {parts}, overlap {overlap}, align {align}: "
                              "need length ≥ 1, parts ≥ 1, overlap ≥ 0, align ≥ 1")
    blocks = math.ceil(length / align)
    n = min(parts, blocks)
    pad = math.ceil(overlap / align) * align
    cuts = [min(length, (blocks * i // n) * align) for i in range(n + 1)]
    cuts[-1] = length
    return tuple(Stripe(i, (cuts[i], cuts[i + 1]), (max(0, cuts[i] - pad), min(length, cuts[i + 1] + pad))) for i in range(n))
