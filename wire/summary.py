"""Percentiles of a sample, as the benchmarks, the reports and the comparison state their figures.

Two definitions, each figure naming its own:

- `"linear"` (numpy's default, `np.percentile(..., method="linear")`): between the two closest ranks,
  interpolated; what every figure uses unless it says otherwise;
- `"rank"`: the element at index ⌊q/100 · n⌋ of the sorted sample (at most n − 1), so always a value
  that was observed (`sidewalk bench secure`'s p50 and p99).

`scale` multiplies the values before the percentile (a change of unit, e.g. 1e6 for [s] → [µs]),
`digits` rounds the result after it; an empty sample gives `empty`. The values are taken as numpy
takes them (`np.asarray`, their own dtype), so a figure is the same number it was when each caller
wrote its own `np.percentile`. Depends on numpy only: bench, sidewalk and compare all import it.
"""

from __future__ import annotations

from typing import Iterable, Literal, Sequence

import numpy as np

__all__ = ["Method", "percentile", "percentiles"]

Method = Literal["linear", "rank"]


def percentile(
    values: Iterable[float] | np.ndarray,
    q: float,
    *,
    method: Method = "linear",
    scale: float = 1.0,
    digits: int | None = None,
    empty: float | None = None,
) -> float | None:
    """Return the q-th percentile (q in [0, 100]) of `values` × `scale`, rounded to `digits`; `empty` if there are none."""
    return percentiles(values, (q,), method=method, scale=scale, digits=digits, empty=empty)[0]


def percentiles(
    values: Iterable[float] | np.ndarray,
    qs: Sequence[float],
    *,
    method: Method = "linear",
    scale: float = 1.0,
    digits: int | None = None,
    empty: float | None = None,
) -> tuple[float | None, ...]:
    """Return the percentiles `qs` (each in [0, 100]) of `values` × `scale`, each rounded to `digits`; `empty` for each if there are none."""
    a = np.asarray(values if isinstance(values, np.ndarray) else list(values))
    if a.size == 0:
        return tuple(empty for _ in qs)
    if scale != 1.0:
        a = a * scale
    if method == "linear":
        out = [float(np.percentile(a, q)) for q in qs]
    elif method == "rank":
        s = np.sort(a.ravel())
        out = [float(s[min(s.size - 1, int(q / 100.0 * s.size))]) for q in qs]
    else:
        raise ValueError(f"percentile method {method!r} is neither 'linear' nor 'rank'")
    return tuple(out if digits is None else (round(v, digits) for v in out))
