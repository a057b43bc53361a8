"""The one percentile helper: each definition gives, to the bit, the figure its callers computed before it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wire.summary import percentile, percentiles


def test_linear_interpolates_between_ranks_and_rank_picks_an_observed_value() -> None:
    xs = [4.0, 1.0, 3.0, 2.0]
    assert percentiles(xs, (50, 99)) == pytest.approx((2.5, 3.97))
    assert percentiles(xs, (50, 99), method="rank") == (3.0, 4.0)
    assert percentile(xs, 0, method="rank") == 1.0 and percentile(xs, 100, method="rank") == 4.0


@pytest.mark.parametrize("n", [1, 2, 3, 7, 10, 99, 100, 101, 257, 1000])
def test_each_definition_equals_the_formula_its_figures_used_before(n: int) -> None:
    rng = np.random.default_rng(n)
    xs = list(rng.lognormal(-8.0, 1.5, n))  # durations [s], spread over decades
    # the benches' and reports' np.percentile (linear), with the unit change made before it
    for scale in (1.0, 1e3, 1e6):
        for q in (50, 95, 99):
            assert percentile(xs, q, scale=scale) == float(np.percentile(np.asarray(xs) * scale, q))
    # `sidewalk bench secure`'s observed values
    s = sorted(xs)
    assert percentiles(xs, (50, 99), method="rank", scale=1e6) == (1e6 * s[len(s) // 2], 1e6 * s[min(len(s) - 1, int(0.99 * len(s)))])
    # the soak bench's and the road following report's rounding after the percentile
    assert percentiles(xs, (50, 99), scale=1e3, digits=3) == tuple(round(float(np.percentile(np.asarray(xs) * 1e3, q)), 3) for q in (50, 99))


def test_values_keep_their_own_dtype_as_numpy_takes_them() -> None:
    a = np.random.default_rng(3).random(11).astype(np.float32)
    assert percentile(a, 95) == float(np.percentile(a, 95))
    assert percentile(a, 95) != float(np.percentile(a.astype(np.float64), 95))


def test_an_empty_sample_gives_the_stated_empty_value() -> None:
    assert percentile([], 50) is None
    assert percentile(iter(()), 50, digits=2) is None
    p50, p99 = percentiles([], (50, 99), empty=math.nan)
    assert math.isnan(p50) and math.isnan(p99)


def test_an_unknown_method_is_refused() -> None:
    with pytest.raises(ValueError, match="neither 'linear' nor 'rank'"):
        percentile([1.0], 50, method="nearest")  # type: ignore[arg-type]


def test_no_source_file_takes_a_percentile_but_the_helper() -> None:
    import re
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    own = re.compile(r"np\.(percentile|quantile|nanpercentile)\(|statistics\.quantiles\(")
    found = sorted(f"{p.relative_to(repo).as_posix()}:{i}" for pkg in ("wire", "blackboard", "modules", "vehicle_sim", "eddie", "sidewalk", "bench")
                   for p in (repo / pkg).rglob("*.py") if p.relative_to(repo).as_posix() != "wire/summary.py"
                   for i, line in enumerate(p.read_text().splitlines(), 1) if own.search(line))
    assert found == []
