"""The point grid (blackboard.pointgrid) and the store's use of it: a box query never misses a point."""

from __future__ import annotations

import numpy as np

from blackboard.pointgrid import PointGrid
from blackboard.spec import Spec, Within
from blackboard.geometry import Polygon
from blackboard.store import Store
from tests.blackboard.conftest import op, pt, square


def _inside(points: dict[int, tuple[float, float]], box: tuple[float, float, float, float]) -> set[int]:
    minx, maxx, miny, maxy = box
    return {r for r, (x, y) in points.items() if minx <= x <= maxx and miny <= y <= maxy}


def test_grid_queries_find_every_point_through_puts_moves_and_removes():
    rng = np.random.default_rng(7)
    grid = PointGrid(cell=5.0)
    truth: dict[int, tuple[float, float]] = {}
    for step in range(3000):
        rid = int(rng.integers(0, 400))
        if rng.random() < 0.25:
            grid.remove(rid)
            truth.pop(rid, None)
        else:
            # some points on cell edges and at negative coordinates, some moved within their cell
            x, y = (float(v) for v in rng.choice([rng.uniform(-60, 60), 5.0 * rng.integers(-12, 12)], size=2))
            grid.put(rid, x, y)
            truth[rid] = (x, y)
        if step % 50 == 0:
            x0, y0 = rng.uniform(-70, 60, size=2)
            w, h = rng.uniform(0, 40, size=2)
            box = (float(x0), float(x0 + w), float(y0), float(y0 + h))
            rids, xy = grid.query(*box)
            got = dict(zip(rids.tolist(), map(tuple, xy.tolist())))
            assert len(got) == len(rids)  # no point twice
            assert _inside(truth, box) <= set(got)
            assert all(truth[r] == p for r, p in got.items())
    assert len(grid) == len(truth)
    rids, xy = grid.query(-1e9, 1e9, -1e9, 1e9)  # more cells than occupied: scans the occupied ones
    assert dict(zip(rids.tolist(), map(tuple, xy.tolist()))) == truth


def test_store_keeps_points_indexed_through_updates_frame_changes_deletes_and_reopen(core, tmp_path):
    ids = [op(core, {"op": "post", "type": "bbt_obstacle", "attrs": {"confidence": 0.5}, "stamp": 0.0, "frame": "world",
                     "geometry": pt(float(i), 1.0)})["id"] for i in range(10)]
    box = Spec(geometry=Within(Polygon(points=[(-0.5, 0.0), (9.5, 0.0), (9.5, 2.0), (-0.5, 2.0)])))

    def found() -> list[str]:
        return [t["id"] for t in core.retrieve(box.model_dump(mode="json"))]

    assert found() == ids
    op(core, {"op": "update", "id": ids[0], "expected_version": 1, "geometry": pt(50.0, 50.0)})  # moved away
    op(core, {"op": "update", "id": ids[1], "expected_version": 1, "geometry": square(0, 0, 1, 1)})  # now a polygon
    op(core, {"op": "update", "id": ids[2], "expected_version": 1, "frame": "elsewhere"})  # another frame
    op(core, {"op": "update", "id": ids[3], "expected_version": 1, "geometry": None})  # no geometry
    op(core, {"op": "delete", "id": ids[4]})
    assert found() == [ids[1]] + ids[5:]
    op(core, {"op": "update", "id": ids[1], "expected_version": 2, "geometry": pt(2.0, 1.5)})  # a point again
    assert found() == [ids[1]] + ids[5:]

    db = str(tmp_path / "g.sqlite")
    store = Store(db)
    for rec in core.store.records.values():
        store.begin()
        store.insert(rec.type, rec.stamp, rec.source, rec.frame, rec.kind, rec.xy, rec.attrs)
        store.commit()
    store.close()
    again = Store(db)
    try:
        def counts(st: Store) -> dict:
            return {(f, t): len(g) for f, grids in st.points.items() for t, g in grids.items()}

        assert counts(again) == counts(core.store) and counts(again)[("world", "bbt_obstacle")] == 7
        def where(st: Store) -> list:
            return sorted((st.records[r].frame, st.records[r].bbox()) for r in st.bbox_query(-0.5, 9.5, 0.0, 2.0))

        assert where(again) == where(core.store) and len(where(again)) == 7
    finally:
        again.close()
