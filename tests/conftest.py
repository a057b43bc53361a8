"""Test-session options shared by every test directory.

`--longest-first` orders the collected tests by their stated time limit (`@pytest.mark.timeout`, which
each test sizes from its measured run time), longest first. With `-n 2 --dist load` (CI's mission and
host stages) the two workers then take the long missions at once and finish on the short ones, instead
of one worker meeting a 3-minute mission at the end while the other sits idle.

Every command a test runs (in-process through Typer's runner, or as a subprocess) prints its errors at
300 columns: at the console's default 80 a tmp path (longer under a pytest-xdist worker) wraps
mid-word inside an error box, and a test looking for the file's name in the message fails for it.
"""

from __future__ import annotations

import os

import pytest

os.environ["COLUMNS"] = "300"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--longest-first", action="store_true", default=False,
                     help="run the tests with the longest time limit (@pytest.mark.timeout) first")


def _limit(item: pytest.Item, default: float) -> float:
    mark = item.get_closest_marker("timeout")
    if mark is None:
        return default
    value = mark.args[0] if mark.args else mark.kwargs.get("timeout", default)
    return float(value) if value is not None else default


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--longest-first"):
        default = float(config.getini("timeout") or 0)
        items.sort(key=lambda item: -_limit(item, default))  # stable: equal limits keep their file order
