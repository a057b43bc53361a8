"""The annotated map's grid and queries: supercover covers every touched cell; queries equal brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from eddie.annotated_map import Annotation, AnnotationDatabase, Grid, Location


def _touched_brute(grid: Grid, p, q) -> set[tuple[int, int]]:
    seg = shapely.LineString([p, q])
    xmin, ymin, xmax, ymax = seg.bounds
    return {c for c in grid.box(xmin, ymin, xmax, ymax)
            if seg.intersects(shapely.box(*grid.cell_box(c))) and
            seg.intersection(shapely.box(*grid.cell_box(c))).length > 1e-9 or
            shapely.box(*grid.cell_box(c)).contains(shapely.Point(p))}


def test_supercover_contains_every_cell_the_segment_passes_through() -> None:
    rng = np.random.default_rng(7)
    grid = Grid(0.5)
    for _ in range(300):
        p = tuple(rng.uniform(-10, 10, 2))
        q = tuple(p + rng.uniform(-4, 4, 2))
        walked = grid.supercover(*p, *q)
        assert walked[0] == grid.cell_of(*p) and walked[-1] == grid.cell_of(*q)
        missing = _touched_brute(grid, p, q) - set(walked)
        assert not missing, (p, q, missing)
        # consecutive cells are 4-neighbours (no diagonal skips as in Bresenham)
        for a, b in zip(walked, walked[1:]):
            assert abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1


def test_supercover_through_a_corner_takes_both_side_cells() -> None:
    walked = Grid(0.5).supercover(0.25, 0.25, 0.75, 0.75)
    assert (0, 0) in walked and (1, 1) in walked and ((1, 0) in walked or (0, 1) in walked)


def _random_annotations(rng: np.random.Generator, n: int) -> list[Annotation]:
    out = []
    for i in range(n):
        cx, cy = rng.uniform(-50, 50, 2)
        kind = ("point", "line", "polygon")[int(rng.integers(3))]
        typ = ("speed", "landmark", "stop")[int(rng.integers(3))]
        if kind == "point":
            loc = Location.point(cx, cy)
        elif kind == "line":
            loc = Location.line([(cx, cy)] + [tuple((cx, cy) + rng.uniform(-5, 5, 2)) for _ in range(int(rng.integers(1, 4)))])
        else:
            r = rng.uniform(0.3, 4)
            ang = np.sort(rng.uniform(0, 2 * math.pi, 5))
            loc = Location.polygon([(cx + r * math.cos(a), cy + r * math.sin(a)) for a in ang])
        out.append(Annotation(id=f"a{i}", type=typ, location=loc))
    return out


def test_queries_equal_brute_force_on_random_annotations() -> None:
    rng = np.random.default_rng(2026)
    anns = _random_annotations(rng, 400)
    db = AnnotationDatabase(anns)
    for _ in range(60):
        cx, cy = rng.uniform(-50, 50, 2)
        w, h = rng.uniform(0.5, 30, 2)
        poly = [(cx, cy), (cx + w, cy + 0.3 * h), (cx + 0.5 * w, cy + h), (cx - 0.2 * w, cy + 0.6 * h)]
        typ = (None, "speed", "landmark", "stop")[int(rng.integers(4))]
        P = shapely.Polygon(poly)
        brute = sorted(a.id for a in anns if (typ is None or a.type == typ) and P.intersects(a.location.geometry()))
        got = [a.id for a in db.query(typ, poly)]
        assert got == brute
    assert [a.id for a in db.query("speed")] == sorted(a.id for a in anns if a.type == "speed")


def test_cells_are_stored_sparsely() -> None:
    far = [Annotation(id="a", type="t", location=Location.point(0, 0)),
           Annotation(id="b", type="t", location=Location.point(1e6, -1e6))]
    db = AnnotationDatabase(far)
    assert db.occupied_cells == 2
    assert [a.id for a in db.query(None, [(1e6 - 1, -1e6 - 1), (1e6 + 1, -1e6 - 1), (1e6 + 1, -1e6 + 1)])] == ["b"]


def test_header_and_data_size() -> None:
    a = Annotation(id="x", type="set_speed", destination="controller", trigger="cross",
                   location=Location.line([(0, 0), (0, 1)]), data=b"abc", next_id="y")
    assert a.data_size == 3 and not a.used
    with pytest.raises(ValueError):
        Annotation(id="x", type="t", trigger="enter", destination="m", location=Location.point(0, 0))
    with pytest.raises(ValueError):
        Annotation(id="x", type="t", trigger="cross", location=Location.point(0, 0))
