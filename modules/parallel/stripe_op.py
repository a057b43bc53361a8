"""A stripe operator: an image function input partitioning may split, and how its arrays are cut.

`StripeOp.fn(inputs, params, stripe)` is a module-level function (workers import it by name). It
gets each partitioned input as the stripe's halo (a view), each `whole` input entire, the pickled
`params`, and the `Stripe`; it returns its outputs over the same halo. Only the core of each
output is kept, so the operator must give on the core what it gives on the whole image: its output
at a pixel may read inputs no farther than `overlap` away along the partitioned axis (the paper's
"overlap by the width of the operator window"). Run on one stripe covering the whole image, it is
the single-process operator itself.

Arrays are cut along `axis` (per array: `axes`), in units of the partition; an array whose extent
is k times the partition length (a finer pyramid level) names k in `scale`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np

from modules.parallel.errors import StripePlanError
from modules.parallel.stripes import Stripe

__all__ = ["StripeOp", "StripeFn", "stripe_length", "pixels_per_unit", "run_stripe"]

#: fn(partitioned halos and whole inputs, params, stripe) → outputs over the halo.
StripeFn = Callable[[Mapping[str, np.ndarray], Any, Stripe], Mapping[str, np.ndarray]]


@dataclass(frozen=True)
class StripeOp:
    """An operator `fn` that reads at most `overlap` [px] across the cut, how its arrays are cut, and on what multiple."""

    fn: StripeFn
    overlap: int = 0
    axis: int = 0
    axes: Mapping[str, int] = field(default_factory=dict)
    scale: Mapping[str, int] = field(default_factory=dict)
    whole: frozenset[str] = frozenset()
    align: int = 1

    def axis_of(self, name: str) -> int:
        """Return the axis array `name` is cut along."""
        return self.axes.get(name, self.axis)

    def cut(self, name: str, arr: np.ndarray, span: tuple[int, int]) -> np.ndarray:
        """Return the part of array `name` over `span` (partition units) along its axis; whole inputs whole."""
        if name in self.whole:
            return arr
        k = self.scale.get(name, 1)
        idx = [slice(None)] * arr.ndim
        idx[self.axis_of(name)] = slice(k * span[0], k * span[1])
        return arr[tuple(idx)]


def stripe_length(op: StripeOp, arrays: Mapping[str, tuple[int, ...]]) -> int:
    """Return the partition length the arrays' shapes agree on; StripePlanError naming the one that does not."""
    length = None
    first = ""
    for name, shape in arrays.items():
        if name in op.whole:
            continue
        ax, k = op.axis_of(name), op.scale.get(name, 1)
        if not -len(shape) <= ax < len(shape):
            raise StripePlanError(f"stripe operator {op.fn.__name__}: array {name!r} of shape {shape} has no axis {ax}")
        if shape[ax] % k:
            raise StripePlanError(f"stripe operator {op.fn.__name__}: array {name!r} extent {shape[ax]} is not a multiple of its scale {k}")
        n = shape[ax] // k
        if length is None:
            length, first = n, name
        elif n != length:
            raise StripePlanError(f"stripe operator {op.fn.__name__}: array {name!r} spans {n} along the cut, {first!r} spans {length}")
    if length is None:
        raise StripePlanError(f"stripe operator {op.fn.__name__}: no array to cut")
    return length


def pixels_per_unit(op: StripeOp, arrays: Mapping[str, tuple[int, ...]]) -> int:
    """Return the pixels one partition unit holds: the other spatial extent of the first cut image (H, W[, C]).

    1 when the first cut array is 1-D or is cut along neither of its first two axes.
    """
    for name, shape in arrays.items():
        if name in op.whole:
            continue
        ax = op.axis_of(name) % len(shape)
        if len(shape) < 2 or ax > 1:
            return 1
        return op.scale.get(name, 1) * int(shape[1 - ax])
    return 1


def run_stripe(op: StripeOp, inputs: Mapping[str, np.ndarray], outputs: Mapping[str, np.ndarray], params: Any, stripe: Stripe) -> None:
    """Run `op` on one stripe of `inputs` and write the core of its results into the full `outputs` arrays."""
    got = op.fn({n: op.cut(n, a, stripe.halo) for n, a in inputs.items()}, params, stripe)
    lo, hi = stripe.inner
    for name, out in outputs.items():
        if name not in got:
            raise StripePlanError(f"stripe operator {op.fn.__name__}: returned no {name!r}")
        res = np.asarray(got[name])
        core = op.cut(name, res, (lo, hi))
        dst = op.cut(name, out, stripe.core)
        if core.shape != dst.shape:
            raise StripePlanError(f"stripe operator {op.fn.__name__}: {name!r} core {core.shape}, expected {dst.shape}")
        np.copyto(dst, core, casting="same_kind")
